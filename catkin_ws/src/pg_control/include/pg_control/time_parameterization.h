// Timing law of joint-space paths (ROS-free): when each waypoint is reached and with what joint velocity, so that a
// joint_trajectory_controller's cubic interpolation stays within the joint velocity limit.
//
// Segment durations follow pg_sim.robot.arm_driver.ArmDriver.follow: T_k = max(|dq_k|_inf / (scale * vmax),
// cartesian_length_k / tool_speed, min_segment_duration). Waypoint velocities: 0 at both ends; at an interior point,
// per joint, the neighbouring secant velocity of smaller magnitude when both have the same sign, else 0 (a monotone
// cubic, no overshoot). A cubic Hermite segment then peaks at <= 1.5 times its secant speed; every segment whose
// peak exceeds scale * vmax is stretched (velocities recomputed) until none does.
#ifndef PG_CONTROL_TIME_PARAMETERIZATION_H
#define PG_CONTROL_TIME_PARAMETERIZATION_H

#include <vector>

#include "pg_control/arm_kinematics.h"

namespace pg_control {

// A timed joint path: positions (rad), velocities (rad/s) and time from start (s) per waypoint; times[0] = 0 and
// times strictly increase. Between waypoints the motion is the cubic Hermite curve of the end positions/velocities.
struct TimedPath {
  std::vector<JointVector> positions;
  std::vector<JointVector> velocities;
  std::vector<double> times;

  double duration() const { return times.empty() ? 0.0 : times.back(); }
  // Position at time t (s), clamped to [0, duration()]. Throws std::logic_error on an empty path.
  JointVector sample(double t) const;
  // Largest joint speed (rad/s) anywhere along the cubic segments (exact, per segment maximum of a quadratic).
  double peakVelocity() const;
  // Largest secant speed max_k |q_k+1 - q_k|_inf / (t_k+1 - t_k) (rad/s).
  double peakSecantVelocity() const;
};

struct TimingOptions {
  double joint_velocity_limit = 3.141592653589793;  // rad/s, every joint (UR5e)
  double velocity_scale = 0.9;                      // fraction of the limit used, as pg_sim (0.9 vmax)
  double min_segment_duration = 1.0 / 240.0;        // s (one PyBullet step)
};

// Times `path` (>= 1 waypoint; 1 gives a single point at t = 0). `cartesian_lengths` holds one TCP length (m) per
// segment, or is empty for a joint-space move; `tool_speed` (m/s) bounds the TCP speed along them. Throws
// std::invalid_argument on inconsistent sizes or non-positive speeds.
TimedPath timeParameterize(const std::vector<JointVector>& path, const std::vector<double>& cartesian_lengths,
                           double tool_speed, const TimingOptions& options);

}  // namespace pg_control

#endif  // PG_CONTROL_TIME_PARAMETERIZATION_H
