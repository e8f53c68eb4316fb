// Unit tests for pg_control's request checks and message wording (primitive_limits.h; ROS-free, no roscore).
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

#include "pg_control/primitive_limits.h"

namespace pg_control {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
const double kNan = std::nan("");

bool contains(const std::string& text, const std::string& part) { return text.find(part) != std::string::npos; }

// The refusal message of resolveTimeout(timeout, limits), or "" when accepted.
std::string timeoutRefusal(double timeout, const TimeoutLimits& limits = {}) {
  try {
    resolveTimeout(timeout, limits);
  } catch (const PrimitiveRefused& e) {
    return e.what();
  }
  return "";
}

TEST(ResolveTimeout, ZeroMeansTheDefault) {
  const TimeoutLimits limits{8.0, 600.0};
  EXPECT_DOUBLE_EQ(resolveTimeout(0.0, limits), 8.0);
  EXPECT_DOUBLE_EQ(resolveTimeout(-0.0, limits), 8.0);
}

TEST(ResolveTimeout, AcceptsValuesUpToTheMaximum) {
  const TimeoutLimits limits{8.0, 600.0};
  EXPECT_DOUBLE_EQ(resolveTimeout(1e-6, limits), 1e-6);  // too short for any plan, refused later with the numbers
  EXPECT_DOUBLE_EQ(resolveTimeout(30.0, limits), 30.0);
  EXPECT_DOUBLE_EQ(resolveTimeout(600.0, limits), 600.0);
}

TEST(ResolveTimeout, RefusesNanNegativeInfiniteAndTooLarge) {
  const struct {
    double timeout;
    const char* shown;
  } cases[] = {{kNan, "nan"},     {-kNan, "nan"},    {kInf, "inf"},
               {-kInf, "-inf"},   {1e308, "1e+308"}, {-1.0, "-1"},
               {-1e-9, "-1e-09"}, {600.5, "600.5"},  {std::numeric_limits<double>::max(), "1.797693135e+308"}};
  for (const auto& c : cases) {
    const std::string why = timeoutRefusal(c.timeout);
    EXPECT_TRUE(contains(why, std::string("timeout = ") + c.shown + " s is refused")) << c.shown << ": " << why;
    EXPECT_TRUE(contains(why, "give 0 (the controller's default, 8.00 s) or a value in (0, 600] s (~max_timeout)"))
        << why;
    EXPECT_TRUE(contains(why, "nothing moved")) << why;
  }
}

TEST(ResolveTimeout, MaximumIsAParameter) {
  const TimeoutLimits limits{2.0, 10.0};
  EXPECT_DOUBLE_EQ(resolveTimeout(10.0, limits), 10.0);
  const std::string why = timeoutRefusal(10.25, limits);
  EXPECT_TRUE(contains(why, "timeout = 10.25 s is refused")) << why;
  EXPECT_TRUE(contains(why, "default, 2.00 s) or a value in (0, 10] s")) << why;
}

TEST(CheckFinite, NamesTheFieldAndValue) {
  EXPECT_NO_THROW(checkFinite("yaw", -3.0));
  EXPECT_NO_THROW(checkFinite("position.point.x", 0.0));
  const struct {
    double value;
    const char* shown;
  } cases[] = {{kNan, "nan"}, {-kNan, "nan"}, {kInf, "inf"}, {-kInf, "-inf"}};
  for (const auto& c : cases) {
    try {
      checkFinite("position.point.z", c.value);
      ADD_FAILURE() << c.shown << " accepted";
    } catch (const PrimitiveRefused& e) {
      EXPECT_EQ(std::string(e.what()),
                std::string("position.point.z = ") + c.shown + " is not a finite number; nothing moved");
    }
  }
}

// The refusal message of checkDeadline(deadline, now), or "" when accepted.
std::string deadlineRefusal(double deadline, double now) {
  try {
    checkDeadline(deadline, now);
  } catch (const PrimitiveRefused& e) {
    return e.what();
  }
  return "";
}

TEST(CheckDeadline, ZeroMeansNone) {
  EXPECT_EQ(deadlineRefusal(0.0, 1.7e9), "");
  EXPECT_EQ(deadlineRefusal(-0.0, 1.7e9), "");
}

TEST(CheckDeadline, AcceptsAFutureDeadline) {
  EXPECT_EQ(deadlineRefusal(1.7e9 + 0.001, 1.7e9), "");
  EXPECT_EQ(deadlineRefusal(1.7e9 + 600.0, 1.7e9), "");
}

TEST(CheckDeadline, RefusesAPassedDeadline) {
  // A request its caller abandoned (e.g. one that waited in a frozen controller) never starts.
  const std::string why = deadlineRefusal(1.7e9, 1.7e9 + 3.2);
  EXPECT_TRUE(contains(why, "abandoned by the caller: deadline passed 3.20 s ago")) << why;
  EXPECT_TRUE(contains(why, "nothing moved")) << why;
  const std::string at = deadlineRefusal(1.7e9, 1.7e9);  // the deadline instant itself is passed
  EXPECT_TRUE(contains(at, "abandoned by the caller: deadline passed 0.00 s ago")) << at;
}

TEST(CheckDeadline, RefusesNanNegativeAndInfinite) {
  for (const double deadline : {kNan, kInf, -kInf, -1.0}) {
    const std::string why = deadlineRefusal(deadline, 1.7e9);
    EXPECT_TRUE(contains(why, "deadline = ")) << deadline << ": " << why;
    EXPECT_TRUE(contains(why, "give 0 (none) or wall-clock seconds since the Unix epoch; nothing moved")) << why;
  }
}

TEST(CheckParameters, RefusesUnusableTimes) {
  EXPECT_NO_THROW(checkSecondsParameter("tf_timeout", 0.5));
  EXPECT_NO_THROW(checkSecondsParameter("goal_time_tolerance", 0.0, true));
  EXPECT_NO_THROW(checkSecondsParameter("max_wall_time", kMaxSecondsParameter));
  for (double bad : {0.0, -1.0, kNan, kInf, 2 * kMaxSecondsParameter}) {
    EXPECT_THROW(checkSecondsParameter("home_timeout", bad), std::invalid_argument) << bad;
  }
  EXPECT_THROW(checkSecondsParameter("goal_time_tolerance", -0.1, true), std::invalid_argument);
  try {
    checkSecondsParameter("home_timeout", kInf);
    ADD_FAILURE() << "inf accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_EQ(std::string(e.what()), "parameter ~home_timeout = inf s: must be in (0, 1000000] s");
  }
  EXPECT_NO_THROW(checkTimeoutLimits({8.0, 600.0}));
  EXPECT_NO_THROW(checkTimeoutLimits({600.0, 600.0}));
  EXPECT_THROW(checkTimeoutLimits({601.0, 600.0}), std::invalid_argument);
  EXPECT_THROW(checkTimeoutLimits({8.0, kInf}), std::invalid_argument);
  EXPECT_THROW(checkTimeoutLimits({0.0, 600.0}), std::invalid_argument);
}

TEST(FormatSeconds, ReadableAtEveryScale) {
  EXPECT_EQ(formatSeconds(8.0), "8.00 s");
  EXPECT_EQ(formatSeconds(3.0549), "3.05 s");
  EXPECT_EQ(formatSeconds(600.0), "600.00 s");
  EXPECT_EQ(formatSeconds(0.0), "0.00 s");
  EXPECT_EQ(formatSeconds(0.25), "0.25 s");
  EXPECT_EQ(formatSeconds(0.123456), "0.123 s");
  EXPECT_EQ(formatSeconds(1e-6), "1e-06 s");  // not "0.00 s"
  EXPECT_EQ(formatSeconds(-2e-3), "-0.002 s");
  EXPECT_EQ(formatSeconds(1.5e6), "1.5e+06 s");
  EXPECT_EQ(formatSeconds(kInf), "inf s");
  EXPECT_EQ(formatSeconds(kNan), "nan s");
}

TEST(FormatNumber, ShowsWhatWasSent) {
  EXPECT_EQ(formatNumber(600.5), "600.5");
  EXPECT_EQ(formatNumber(600.0000001), "600.0000001");  // not rounded to the maximum it exceeds
  EXPECT_EQ(formatNumber(-kNan), "nan");
  EXPECT_EQ(formatNumber(-kInf), "-inf");
}

TEST(DescribeLimits, NameTheLimitAndItsNumbers) {
  EXPECT_EQ(describeTimeout("the primitive", 1e-6), "the primitive's timeout of 1e-06 s");
  EXPECT_EQ(describeTimeout("the return home", 8.0), "the return home's timeout of 8.00 s");
  EXPECT_EQ(describeMoveLimit(0.4321, 1.0), "its planned duration of 0.432 s plus goal_time_tolerance of 1.00 s");
}

}  // namespace
}  // namespace pg_control

// catkin_add_gtest links GTest::gtest only (no gtest_main), so the test brings its own main().
int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
