// Straight-line Cartesian motion of the tool-down TCP turned into joint waypoints (ROS-free), as
// pg_sim.world.primitives.PrimitiveExecutor._plan_arm: every leg a -> b of a polyline is cut into
// n = max(1, ceil(|b - a| / step)) equal steps, and each waypoint's IK is seeded from the previous waypoint.
#ifndef PG_CONTROL_CARTESIAN_PATH_H
#define PG_CONTROL_CARTESIAN_PATH_H

#include <Eigen/Core>
#include <stdexcept>
#include <string>
#include <vector>

#include "pg_control/arm_kinematics.h"

namespace pg_control {

// A planning failure (unreachable waypoint, joint jump); what() says where.
class PlanningError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// Joint waypoints of a Cartesian polyline. joints[0] is the start configuration; lengths[k] is the Cartesian length
// (m) of the step joints[k] -> joints[k + 1]; points[k] the TCP position (world, m) of joints[k].
struct CartesianPath {
  std::vector<JointVector> joints;
  std::vector<Eigen::Vector3d> points;
  std::vector<double> lengths;

  double length() const;  // total Cartesian length (m)
};

struct CartesianPathOptions {
  double step = 0.01;      // waypoint spacing (m), primitives.waypoint_step
  double max_jump = 0.5;   // largest joint change between waypoints (rad): more is a branch or wrist flip
};

// Follows `polyline` (world, m; at least 2 points) with the TCP pointing down at `yaw` (rad), starting from
// `q_start`, which must already reach polyline[0] (it is not re-solved). Throws PlanningError naming the failing
// waypoint when IK fails or a step jumps more than options.max_jump, std::invalid_argument for bad arguments.
CartesianPath planCartesianPath(const ArmKinematics& arm, const std::vector<Eigen::Vector3d>& polyline, double yaw,
                                const JointVector& q_start, const CartesianPathOptions& options);

// The number of equal steps of a leg of length `length` (m): max(1, ceil(length / step)), with a 1e-9 relative
// allowance so that a leg of exactly k steps is not cut into k + 1 by rounding noise.
int stepCount(double length, double step);

}  // namespace pg_control

#endif  // PG_CONTROL_CARTESIAN_PATH_H
