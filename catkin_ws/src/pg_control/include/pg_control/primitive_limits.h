// Limits of one /pg/execute_primitive call, ROS-free: which request numbers are accepted (the timeout's range, finite
// position and yaw, a deadline not yet passed), which time parameters the controller starts with, and how durations
// and limits are worded in its answers. Every refusal here is a PrimitiveRefused whose what() names the field and its
// value and ends with "nothing moved"; the controller checks the request with these functions before it plans or
// commands anything.
#ifndef PG_CONTROL_PRIMITIVE_LIMITS_H
#define PG_CONTROL_PRIMITIVE_LIMITS_H

#include <string>

#include "pg_control/primitive_planner.h"

namespace pg_control {

// Largest value of any time parameter (s). ros::Duration holds at most 2^31 s; this ceiling leaves room for the ROS
// time it is added to.
constexpr double kMaxSecondsParameter = 1e6;

// Range of a request's `timeout` (s, ROS time).
struct TimeoutLimits {
  double default_timeout = 8.0;  // used when the request gives 0; in (0, max_timeout]
  double max_timeout = 600.0;    // the largest timeout accepted; in (0, kMaxSecondsParameter]
};

// The time budget (s, ROS time) of a request whose `timeout` field is `timeout` (s): `timeout` itself when in
// (0, max_timeout], limits.default_timeout when 0. Throws PrimitiveRefused for NaN, negative, infinite or larger
// values, e.g. "timeout = inf s is refused: give 0 (the controller's default, 8.00 s) or a value in (0, 600] s
// (~max_timeout); nothing moved".
double resolveTimeout(double timeout, const TimeoutLimits& limits);

// Throws PrimitiveRefused when `value` is NaN or infinite: "<field> = <value> is not a finite number; nothing moved".
void checkFinite(const std::string& field, double value);

// A request's `deadline`: wall-clock seconds since the Unix epoch after which its caller no longer waits for the
// answer; 0 = none. Called with the same clock's `now` (s) when the request is taken up and again just before its
// first command. Throws PrimitiveRefused for NaN, negative or infinite values ("deadline = nan s is refused: give 0
// (none) or wall-clock seconds since the Unix epoch; nothing moved") and when the deadline is at or before `now`
// ("abandoned by the caller: deadline passed 3.20 s ago; nothing moved").
void checkDeadline(double deadline, double now);

// Throws std::invalid_argument naming the parameter `name` unless `value` (s) is finite, at most
// kMaxSecondsParameter, and > 0 (>= 0 when `zero_allowed`).
void checkSecondsParameter(const std::string& name, double value, bool zero_allowed = false);
// Checks both parameters as above and default_timeout <= max_timeout; throws std::invalid_argument.
void checkTimeoutLimits(const TimeoutLimits& limits);

// A number as it appears in messages: up to 10 significant digits, "nan" / "inf" / "-inf" when not finite.
std::string formatNumber(double value);
// A duration (s) readable at every scale: "8.00 s", "0.25 s", "1e-06 s", "1.5e+06 s", "inf s".
std::string formatSeconds(double seconds);
// The limit of a move that ended at its planned duration plus the tolerance (s), worded for "did not finish within
// ...": "its planned duration of 0.43 s plus goal_time_tolerance of 1.00 s".
std::string describeMoveLimit(double planned, double tolerance);
// The limit of a whole primitive, worded likewise: "the primitive's timeout of 8.00 s".
std::string describeTimeout(const std::string& whose, double seconds);

}  // namespace pg_control

#endif  // PG_CONTROL_PRIMITIVE_LIMITS_H
