// Unit tests for pg_control::timeParameterize (ROS-free; no roscore).
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <stdexcept>
#include <vector>

#include "pg_control/time_parameterization.h"

namespace pg_control {
namespace {

constexpr double kPi = 3.14159265358979323846;

JointVector joints(double a, double b = 0.0) {
  JointVector q = JointVector::Zero(6);
  q(0) = a;
  q(3) = b;
  return q;
}

// Largest joint speed found by finite differences of TimedPath::sample (rad/s).
double sampledPeak(const TimedPath& p) {
  double peak = 0.0;
  const double dt = 1e-4;
  for (double t = 0.0; t + dt <= p.duration(); t += dt) {
    peak = std::max(peak, (p.sample(t + dt) - p.sample(t)).cwiseAbs().maxCoeff() / dt);
  }
  return peak;
}

TEST(TimeParameterization, SingleJointMoveStaysWithinTheLimit) {
  TimingOptions opt;
  const TimedPath p = timeParameterize({joints(0.0), joints(2.0)}, {}, 1.0, opt);
  ASSERT_EQ(p.times.size(), 2u);
  EXPECT_DOUBLE_EQ(p.times[0], 0.0);
  // Rest to rest: the cubic peaks at 1.5x its mean speed, so the move takes 1.5 * 2 rad / (0.9 pi rad/s).
  EXPECT_NEAR(p.duration(), 1.5 * 2.0 / (0.9 * kPi), 1e-4);
  EXPECT_LE(p.peakVelocity(), 0.9 * kPi * (1 + 1e-6));
  EXPECT_NEAR(sampledPeak(p), p.peakVelocity(), 1e-3);
  EXPECT_TRUE(p.velocities.front().isZero());
  EXPECT_TRUE(p.velocities.back().isZero());
  EXPECT_LT((p.sample(p.duration()) - joints(2.0)).norm(), 1e-12);
  EXPECT_LT((p.sample(0.0) - joints(0.0)).norm(), 1e-12);
}

TEST(TimeParameterization, CartesianSpeedBoundsSlowSegments) {
  // 11 waypoints 1 cm apart at 0.1 m/s: each segment takes 0.1 s; joints move slowly, so the tool speed rules.
  std::vector<JointVector> path;
  std::vector<double> lengths;
  for (int i = 0; i <= 10; ++i) {
    path.push_back(joints(0.01 * i, -0.02 * i));
    if (i) lengths.push_back(0.01);
  }
  const TimedPath p = timeParameterize(path, lengths, 0.1, TimingOptions());
  for (std::size_t k = 0; k + 1 < p.times.size(); ++k) EXPECT_NEAR(p.times[k + 1] - p.times[k], 0.1, 1e-9);
  // Interior velocities are the (equal) secant velocities: constant speed along the line.
  EXPECT_NEAR(p.velocities[5](0), 0.1, 1e-9);
  EXPECT_NEAR(p.velocities[5](3), -0.2, 1e-9);
}

TEST(TimeParameterization, RandomPathsRespectTheLimitAndTimesIncrease) {
  std::mt19937 rng(11);
  std::normal_distribution<double> step(0.0, 0.3);
  std::uniform_real_distribution<double> len(0.0, 0.02);
  TimingOptions opt;
  for (int trial = 0; trial < 50; ++trial) {
    std::vector<JointVector> path{JointVector::Zero(6)};
    std::vector<double> lengths;
    for (int i = 0; i < 20; ++i) {
      JointVector q = path.back();
      for (int j = 0; j < 6; ++j) q(j) += step(rng) * (i % 7 == 3 ? 5.0 : 1.0);
      path.push_back(q);
      lengths.push_back(len(rng));
    }
    const TimedPath p = timeParameterize(path, lengths, 0.3, opt);
    ASSERT_EQ(p.times.size(), path.size());
    for (std::size_t k = 0; k + 1 < p.times.size(); ++k) {
      ASSERT_GE(p.times[k + 1] - p.times[k], opt.min_segment_duration - 1e-12);
      ASSERT_GE(p.times[k + 1] - p.times[k], lengths[k] / 0.3 - 1e-12);
    }
    EXPECT_LE(p.peakVelocity(), 0.9 * kPi * (1 + 1e-6)) << trial;
    EXPECT_LE(p.peakSecantVelocity(), 0.9 * kPi * (1 + 1e-6)) << trial;
    for (const auto& v : p.velocities) EXPECT_LE(v.cwiseAbs().maxCoeff(), 0.9 * kPi * (1 + 1e-6));
    EXPECT_LE(sampledPeak(p), 0.9 * kPi * 1.001) << trial;
  }
}

TEST(TimeParameterization, DegenerateInput) {
  const TimedPath one = timeParameterize({joints(1.0)}, {}, 1.0, TimingOptions());
  EXPECT_EQ(one.times.size(), 1u);
  EXPECT_DOUBLE_EQ(one.duration(), 0.0);
  // A zero-length segment still takes the minimum duration (strictly increasing times).
  const TimedPath still = timeParameterize({joints(1.0), joints(1.0)}, {0.0}, 0.3, TimingOptions());
  EXPECT_GT(still.duration(), 0.0);
  EXPECT_THROW(timeParameterize({}, {}, 1.0, TimingOptions()), std::invalid_argument);
  EXPECT_THROW(timeParameterize({joints(0), joints(1)}, {0.1, 0.2}, 1.0, TimingOptions()), std::invalid_argument);
  EXPECT_THROW(timeParameterize({joints(0), joints(1)}, {0.1}, 0.0, TimingOptions()), std::invalid_argument);
  EXPECT_THROW(timeParameterize({joints(0), JointVector::Zero(5)}, {}, 1.0, TimingOptions()), std::invalid_argument);
}

}  // namespace
}  // namespace pg_control

// catkin_add_gtest links GTest::gtest only (no gtest_main), so the test brings its own main().
int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
