// Push and grasp primitives (DESIGN.md section 4, docs/ARCHITECTURE.md) planned into timed joint-space steps,
// ROS-free. The step sequence, heights, speeds, arm choice and refusals are those of pg_sim.world.primitives:
//
//   grasp: open gripper (no wait) -> transit (joint space, current -> above the pre-pose at transit_height) ->
//          line above -> pre-grasp -> grasp point (cartesian_speed) -> close gripper (wait) -> lift by lift_height
//          (cartesian_speed) -> check grasp (opening > gripper.closed_threshold) -> home (joint space) ->
//          open gripper (wait; releases a held object outside the workspace)
//   push:  close gripper (no wait) -> transit -> line above -> pre-push -> push start (cartesian_speed) -> push
//          push_length along (cos yaw, sin yaw), end clipped to the workspace (push_speed) -> retreat up by
//          approach_height (cartesian_speed) -> home -> open gripper (wait)
//
// Refusals (PrimitiveRefused, nothing planned): an action point outside the workspace box (grasp: grasp point,
// pre-grasp, lift; push: start, pre-push), an unknown arm, non-finite input, or no IK along the whole path for any
// allowed arm. Arms are tried closest base first (distance in the table plane to the pre-pose), unless one is named.
#ifndef PG_CONTROL_PRIMITIVE_PLANNER_H
#define PG_CONTROL_PRIMITIVE_PLANNER_H

#include <pg_core/workspace_config.h>

#include <Eigen/Core>
#include <map>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "pg_control/arm_kinematics.h"
#include "pg_control/time_parameterization.h"

namespace pg_control {

enum class PrimitiveType { kPush, kGrasp };

// A request; `position` is the TCP action point in `world` (m), yaw in rad, arm "" (automatic) or an arm name.
struct PrimitiveRequest {
  PrimitiveType type = PrimitiveType::kGrasp;
  Eigen::Vector3d position = Eigen::Vector3d::Zero();
  double yaw = 0.0;
  std::string arm;
};

// The request cannot be executed; what() says why. Nothing has moved.
class PrimitiveRefused : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// One step of a plan.
struct PrimitiveStep {
  enum class Kind {
    kMove,        // follow `motion` (joint trajectory)
    kGripper,     // command `opening` (m); wait for it (reached or stalled) when `wait`
    kCheckGrasp,  // grasped = opening > gripper.closed_threshold
  };
  Kind kind = Kind::kMove;
  std::string name;  // "transit", "approach", "lift", "push", "retreat", "home", "open", "close", "release", "check"
  TimedPath motion;  // kMove only
  std::vector<Eigen::Vector3d> tcp_points;  // kMove of a Cartesian line: TCP position (world, m) per waypoint
  double opening = 0.0;                     // kGripper only (m)
  bool wait = false;                        // kGripper only
};

struct PrimitivePlan {
  PrimitiveType type = PrimitiveType::kGrasp;
  std::string arm;
  std::vector<PrimitiveStep> steps;  // in execution order; the last two are "home" and "release"
  double motionDuration() const;     // sum of the kMove durations (s)
};

class PrimitivePlanner {
 public:
  // Builds the kinematics of every arm of `config` from the URDF `model` (root link = `world`). Throws
  // std::runtime_error when the URDF and the config disagree (missing links, wrong joint count).
  PrimitivePlanner(const pg_core::WorkspaceConfig& config, const urdf::ModelInterface& model);

  const pg_core::WorkspaceConfig& config() const { return config_; }
  std::vector<std::string> armNames() const;
  // Throws std::invalid_argument for an unknown arm.
  const ArmKinematics& arm(const std::string& name) const;

  // Plans `request`; `current` maps arm name -> its current joints (rad), needed for every arm that may be chosen.
  // Throws PrimitiveRefused (see above) or std::invalid_argument when a needed arm's joints are missing.
  PrimitivePlan plan(const PrimitiveRequest& request, const std::map<std::string, JointVector>& current) const;

  // Arms to try for an action at `xy` (world, m): [arm] when named (PrimitiveRefused if unknown), else all arms by
  // distance of their base to xy, closest first (file order on ties).
  std::vector<std::string> armOrder(const std::string& arm, const Eigen::Vector2d& xy) const;

  // Timed joint-space move from `from` to `to` of arm `name` (no Cartesian constraint).
  TimedPath jointMove(const std::string& name, const JointVector& from, const JointVector& to) const;
  // The home configuration of arm `name` (rad).
  const JointVector& home(const std::string& name) const { return arm(name).home(); }

  TimingOptions timingOptions() const;

 private:
  void checkWorkspace(const std::vector<std::pair<std::string, Eigen::Vector3d>>& points) const;
  // Plans the steps for one arm; throws PlanningError when unreachable.
  PrimitivePlan planArm(const std::string& name, const PrimitiveRequest& request,
                        const std::vector<std::vector<Eigen::Vector3d>>& lines, const JointVector& current) const;

  pg_core::WorkspaceConfig config_;
  std::map<std::string, std::unique_ptr<ArmKinematics>> arms_;
};

const char* toString(PrimitiveType type);

}  // namespace pg_control

#endif  // PG_CONTROL_PRIMITIVE_PLANNER_H
