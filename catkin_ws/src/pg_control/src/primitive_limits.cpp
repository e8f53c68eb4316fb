#include "pg_control/primitive_limits.h"

#include <cmath>
#include <cstdio>
#include <stdexcept>

namespace pg_control {
namespace {

std::string printf1(const char* format, double value) {
  char buf[64];
  std::snprintf(buf, sizeof(buf), format, value);
  return buf;
}

// Non-finite values spelled alike on every platform (printf may write "-nan").
std::string nonFinite(double value) {
  if (std::isnan(value)) return "nan";
  return value > 0.0 ? "inf" : "-inf";
}

}  // namespace

std::string formatNumber(double value) {
  if (!std::isfinite(value)) return nonFinite(value);
  return printf1("%.10g", value);
}

std::string formatSeconds(double seconds) {
  if (!std::isfinite(seconds)) return nonFinite(seconds) + " s";
  const double magnitude = std::abs(seconds);
  if (magnitude == 0.0 || (magnitude >= 1.0 && magnitude < 1e5)) return printf1("%.2f s", seconds);
  return printf1("%.3g s", seconds);  // small or huge: significant digits, never "0.00 s"
}

std::string describeMoveLimit(double planned, double tolerance) {
  return "its planned duration of " + formatSeconds(planned) + " plus goal_time_tolerance of " +
         formatSeconds(tolerance);
}

std::string describeTimeout(const std::string& whose, double seconds) {
  return whose + "'s timeout of " + formatSeconds(seconds);
}

double resolveTimeout(double timeout, const TimeoutLimits& limits) {
  if (timeout == 0.0) return limits.default_timeout;
  if (std::isfinite(timeout) && timeout > 0.0 && timeout <= limits.max_timeout) return timeout;
  throw PrimitiveRefused("timeout = " + formatNumber(timeout) + " s is refused: give 0 (the controller's default, " +
                         formatSeconds(limits.default_timeout) + ") or a value in (0, " +
                         formatNumber(limits.max_timeout) + "] s (~max_timeout); nothing moved");
}

void checkFinite(const std::string& field, double value) {
  if (!std::isfinite(value)) {
    throw PrimitiveRefused(field + " = " + formatNumber(value) + " is not a finite number; nothing moved");
  }
}

void checkDeadline(double deadline, double now) {
  if (deadline == 0.0) return;
  if (!std::isfinite(deadline) || deadline < 0.0) {
    throw PrimitiveRefused("deadline = " + formatNumber(deadline) +
                           " s is refused: give 0 (none) or wall-clock seconds since the Unix epoch; nothing moved");
  }
  if (deadline <= now) {
    throw PrimitiveRefused("abandoned by the caller: deadline passed " + formatSeconds(now - deadline) +
                           " ago; nothing moved");
  }
}

void checkSecondsParameter(const std::string& name, double value, bool zero_allowed) {
  const bool low = zero_allowed ? value < 0.0 : value <= 0.0;
  if (!std::isfinite(value) || low || value > kMaxSecondsParameter) {
    throw std::invalid_argument("parameter ~" + name + " = " + formatNumber(value) + " s: must be " +
                                (zero_allowed ? "in [0, " : "in (0, ") + formatNumber(kMaxSecondsParameter) + "] s");
  }
}

void checkTimeoutLimits(const TimeoutLimits& limits) {
  checkSecondsParameter("default_timeout", limits.default_timeout);
  checkSecondsParameter("max_timeout", limits.max_timeout);
  if (limits.default_timeout > limits.max_timeout) {
    throw std::invalid_argument("parameter ~default_timeout = " + formatNumber(limits.default_timeout) +
                                " s is above ~max_timeout = " + formatNumber(limits.max_timeout) + " s");
  }
}

}  // namespace pg_control
