// Kinematics of one UR5e arm of the project's URDF: KDL chain `<arm>_base_link` -> `<arm>_gripper_tcp`, forward
// kinematics and seeded, branch-aware inverse kinematics (ROS-free).
//
// Frames: `world` (the URDF root), `<arm>_base_link`, `<arm>_gripper_tcp` (fingertip centre, gripper.tcp_offset along
// tool0 z). Units: metres, radians. Joint vectors hold the 6 arm joints shoulder_pan .. wrist_3 in chain order.
#ifndef PG_CONTROL_ARM_KINEMATICS_H
#define PG_CONTROL_ARM_KINEMATICS_H

#include <pg_core/workspace_config.h>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "pg_control/urdf_chain.h"

namespace KDL {
class ChainIkSolverPos_LMA;
}  // namespace KDL

namespace pg_control {

using JointVector = Eigen::VectorXd;

// One of the 8 closed-form UR IK branches, with the signs of pg_sim.robot.ur_ik (and of `robot.arms.<arm>.ik_branch`):
// shoulder: sign s1 in q1 = atan2(p05) + s1 acos(d4 / r) + pi/2 (p05 = wrist centre, DH frame 5 origin);
// wrist: sign of sin(q5); elbow: sign of sin(q3).
struct IkBranch {
  int shoulder = 1;
  int wrist = -1;
  int elbow = 1;
  bool operator==(const IkBranch& o) const { return shoulder == o.shoulder && wrist == o.wrist && elbow == o.elbow; }
  bool operator!=(const IkBranch& o) const { return !(*this == o); }
};

struct IkOptions {
  bool require_branch = true;        // accept only solutions on the arm's configured branch
  int max_restarts = 30;             // random restarts after the attempt from the seed
  int max_solutions = 1;             // without require_branch: collect this many, return the closest to the seed
  unsigned int random_seed = 1;      // restart seeds are reproducible (same request -> same answer)
  double position_tolerance = 1e-5;  // accepted TCP position residual (m)
  double rotation_tolerance = 1e-4;  // accepted TCP orientation residual (rad)
};

class ArmKinematics {
 public:
  // Arm `arm.name` of `model` (root link `world_frame`). Joint limits are the intersection of the URDF's and the
  // config's (`robot.joint_lower/upper`), the velocity limit the smaller of the two, the branch `arm.ik_branch`.
  // Throws std::runtime_error when a link is missing or the chain does not hold exactly 6 movable joints.
  ArmKinematics(const urdf::ModelInterface& model, const std::string& world_frame, const pg_core::ArmSpec& arm,
                const pg_core::RobotParams& robot);
  ~ArmKinematics();
  ArmKinematics(const ArmKinematics&) = delete;  // the KDL solvers refer to chain_
  ArmKinematics& operator=(const ArmKinematics&) = delete;

  const std::string& name() const { return name_; }
  const std::vector<std::string>& jointNames() const { return joint_names_; }  // e.g. "left_shoulder_pan_joint"
  const JointVector& lower() const { return lower_; }                          // rad
  const JointVector& upper() const { return upper_; }                          // rad
  double velocityLimit() const { return velocity_limit_; }                     // rad/s, every joint
  const JointVector& home() const { return home_; }                            // rad
  const IkBranch& branch() const { return branch_; }
  const Eigen::Isometry3d& worldFromBase() const { return world_from_base_; }  // world <- <arm>_base_link

  // world <- <arm>_gripper_tcp at joint angles q (rad). Throws std::invalid_argument for a q that is not 6 long.
  Eigen::Isometry3d fk(const JointVector& q) const;
  // world <- `link` for a link of the chain (e.g. "<arm>_tool0"). Throws std::invalid_argument for another link.
  Eigen::Isometry3d fkLink(const JointVector& q, const std::string& link) const;

  // The closed-form branch that q lies on.
  IkBranch branchOf(const JointVector& q) const;
  // True when q is on `branch` (joints exactly at a branch boundary count as on it).
  bool isOnBranch(const JointVector& q, const IkBranch& branch) const;
  bool withinLimits(const JointVector& q) const;

  // Joint angles (rad) putting the TCP at `world_T_tcp`, nearest `seed`: KDL LMA from the seed, then from seeded
  // random restarts; each result is shifted by multiples of 2 pi towards the seed within the joint limits (as
  // pg_sim.robot.ur_ik.closest) and verified with FK. With require_branch, the solution lies on branch(), where it is
  // unique up to those shifts, so the controller picks the same configuration as the simulator. std::nullopt when none
  // is found. Throws std::invalid_argument for a seed that is not 6 finite numbers. Thread-safe.
  std::optional<JointVector> solve(const Eigen::Isometry3d& world_T_tcp, const JointVector& seed,
                                   const IkOptions& options = IkOptions()) const;
  // Same for the tool-down TCP pose at `position` (world, m) with closing axis (cos yaw, sin yaw, 0).
  std::optional<JointVector> solveDown(const Eigen::Vector3d& position, double yaw, const JointVector& seed,
                                       const IkOptions& options = IkOptions()) const;

  // q shifted joint by joint by multiples of 2 pi to lie nearest `seed` within the limits; nullopt when a joint
  // cannot be brought within its limits.
  std::optional<JointVector> shiftTowards(const JointVector& q, const JointVector& seed) const;

 private:
  void checkJoints(const JointVector& q, const char* what) const;

  std::string name_;
  UrdfChain chain_;
  std::vector<std::string> joint_names_;
  JointVector lower_;
  JointVector upper_;
  double velocity_limit_ = 0.0;
  JointVector home_;
  IkBranch branch_;
  Eigen::Isometry3d world_from_base_ = Eigen::Isometry3d::Identity();
  int wrist_centre_segment_ = -1;  // number of segments up to `<arm>_wrist_3_link` (its origin = DH frame 5 origin)
  std::unique_ptr<KDL::ChainIkSolverPos_LMA> ik_solver_;
  mutable std::mutex ik_mutex_;  // KDL solvers keep scratch state
};

}  // namespace pg_control

#endif  // PG_CONTROL_ARM_KINEMATICS_H
