// Tool-down TCP poses and pose errors (header only, ROS-free). Frames: `world` (REP 103), metres, radians.
#ifndef PG_CONTROL_TOOL_POSE_H
#define PG_CONTROL_TOOL_POSE_H

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>

namespace pg_control {

// Pose in `world` of a tool pointing straight down (tool z = -world z) whose x axis (the gripper's closing axis) is
// (cos yaw, sin yaw, 0), at `position` (m). Same as pg_sim.robot.kinematics.down_pose.
inline Eigen::Isometry3d toolDownPose(const Eigen::Vector3d& position, double yaw) {
  const double c = std::cos(yaw);
  const double s = std::sin(yaw);
  Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
  t.linear() << c, s, 0.0,  //
      s, -c, 0.0,           //
      0.0, 0.0, -1.0;
  t.translation() = position;
  return t;
}

// Distance between the origins of two poses (m).
inline double positionError(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b) {
  return (a.translation() - b.translation()).norm();
}

// Angle of the rotation between two poses (rad, in [0, pi]).
inline double rotationError(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b) {
  const Eigen::Matrix3d d = a.linear().transpose() * b.linear();
  const double c = std::clamp((d.trace() - 1.0) / 2.0, -1.0, 1.0);
  // acos loses precision near 0; use the skew part there.
  const Eigen::Vector3d w(d(2, 1) - d(1, 2), d(0, 2) - d(2, 0), d(1, 0) - d(0, 1));
  return std::atan2(0.5 * w.norm(), c);
}

}  // namespace pg_control

#endif  // PG_CONTROL_TOOL_POSE_H
