#include "pg_control/arm_kinematics.h"

#include <algorithm>
#include <cmath>
#include <kdl/chainfksolverpos_recursive.hpp>
#include <kdl/chainiksolverpos_lma.hpp>
#include <kdl/jntarray.hpp>
#include <limits>
#include <random>
#include <stdexcept>

#include "pg_control/tool_pose.h"

namespace pg_control {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kTwoPi = 2.0 * kPi;
constexpr double kBranchTolerance = 1e-9;
constexpr double kLmaEps = 1e-10;  // LMA stops when its weighted pose error is below this
constexpr int kLmaMaxIterations = 300;

double wrapToPi(double a) { return a - kTwoPi * std::floor((a + kPi) / kTwoPi); }

KDL::JntArray toJnt(const JointVector& q) {
  KDL::JntArray j(static_cast<unsigned int>(q.size()));
  j.data = q;
  return j;
}

}  // namespace

ArmKinematics::ArmKinematics(const urdf::ModelInterface& model, const std::string& world_frame,
                             const pg_core::ArmSpec& arm, const pg_core::RobotParams& robot)
    : name_(arm.name) {
  const std::string prefix = arm.name + "_";
  chain_ = chainFromUrdf(model, prefix + "base_link", prefix + "gripper_tcp");
  if (chain_.joint_names.size() != 6) {
    throw std::runtime_error("arm '" + name_ + "': chain " + prefix + "base_link -> " + prefix + "gripper_tcp has " +
                             std::to_string(chain_.joint_names.size()) + " movable joints, expected 6");
  }
  joint_names_ = chain_.joint_names;
  world_from_base_ = fixedTransform(model, world_frame, prefix + "base_link");

  lower_.resize(6);
  upper_.resize(6);
  velocity_limit_ = robot.joint_velocity_limit;
  for (int i = 0; i < 6; ++i) {
    lower_(i) = std::max(chain_.lower[i], robot.joint_lower[i]);
    upper_(i) = std::min(chain_.upper[i], robot.joint_upper[i]);
    velocity_limit_ = std::min(velocity_limit_, chain_.velocity[i]);
    if (!(lower_(i) < upper_(i))) {
      throw std::runtime_error("arm '" + name_ + "': empty joint range for " + joint_names_[i]);
    }
  }
  home_ = Eigen::Map<const Eigen::Matrix<double, 6, 1>>(arm.home.data());
  branch_ = IkBranch{arm.ik_branch[0], arm.ik_branch[1], arm.ik_branch[2]};

  const auto& segs = chain_.segment_names;
  const auto it = std::find(segs.begin(), segs.end(), prefix + "wrist_3_link");
  if (it == segs.end()) throw std::runtime_error("arm '" + name_ + "': no link " + prefix + "wrist_3_link in chain");
  wrist_centre_segment_ = static_cast<int>(it - segs.begin()) + 1;

  // Position and orientation weighted alike (1 m ~ 1 rad): the TCP must be exact in both.
  Eigen::Matrix<double, 6, 1> weights = Eigen::Matrix<double, 6, 1>::Ones();
  ik_solver_ = std::make_unique<KDL::ChainIkSolverPos_LMA>(chain_.chain, weights, kLmaEps, kLmaMaxIterations, 1e-15);
}

ArmKinematics::~ArmKinematics() = default;

void ArmKinematics::checkJoints(const JointVector& q, const char* what) const {
  if (q.size() != 6 || !q.allFinite()) {
    throw std::invalid_argument(std::string("arm '") + name_ + "': " + what + " must be 6 finite joint angles");
  }
}

Eigen::Isometry3d ArmKinematics::fk(const JointVector& q) const {
  checkJoints(q, "q");
  KDL::ChainFkSolverPos_recursive solver(chain_.chain);
  KDL::Frame f;
  solver.JntToCart(toJnt(q), f);
  return world_from_base_ * toEigen(f);
}

Eigen::Isometry3d ArmKinematics::fkLink(const JointVector& q, const std::string& link) const {
  checkJoints(q, "q");
  const auto& segs = chain_.segment_names;
  const auto it = std::find(segs.begin(), segs.end(), link);
  if (it == segs.end()) throw std::invalid_argument("arm '" + name_ + "': link '" + link + "' not in its chain");
  KDL::ChainFkSolverPos_recursive solver(chain_.chain);
  KDL::Frame f;
  solver.JntToCart(toJnt(q), f, static_cast<int>(it - segs.begin()) + 1);
  return world_from_base_ * toEigen(f);
}

IkBranch ArmKinematics::branchOf(const JointVector& q) const {
  checkJoints(q, "q");
  KDL::ChainFkSolverPos_recursive solver(chain_.chain);
  KDL::Frame wrist;
  solver.JntToCart(toJnt(q), wrist, wrist_centre_segment_);  // base_link <- wrist_3_link; origin = p05
  const double delta = wrapToPi(q(0) - std::atan2(wrist.p.y(), wrist.p.x()) - kPi / 2.0);
  return IkBranch{delta >= 0.0 ? 1 : -1, std::sin(q(4)) >= 0.0 ? 1 : -1, std::sin(q(2)) >= 0.0 ? 1 : -1};
}

bool ArmKinematics::isOnBranch(const JointVector& q, const IkBranch& branch) const {
  checkJoints(q, "q");
  KDL::ChainFkSolverPos_recursive solver(chain_.chain);
  KDL::Frame wrist;
  solver.JntToCart(toJnt(q), wrist, wrist_centre_segment_);
  const double delta = wrapToPi(q(0) - std::atan2(wrist.p.y(), wrist.p.x()) - kPi / 2.0);
  return branch.shoulder * delta >= -kBranchTolerance && branch.wrist * std::sin(q(4)) >= -kBranchTolerance &&
         branch.elbow * std::sin(q(2)) >= -kBranchTolerance;
}

bool ArmKinematics::withinLimits(const JointVector& q) const {
  checkJoints(q, "q");
  return ((q - lower_).array() >= -1e-9).all() && ((upper_ - q).array() >= -1e-9).all();
}

std::optional<JointVector> ArmKinematics::shiftTowards(const JointVector& q, const JointVector& seed) const {
  checkJoints(q, "q");
  checkJoints(seed, "seed");
  JointVector out(6);
  for (int k = 0; k < 6; ++k) {
    double v = q(k) + kTwoPi * std::round((seed(k) - q(k)) / kTwoPi);
    if (v > upper_(k)) {
      v -= kTwoPi;  // the nearest shift left the range: try the other side
    } else if (v < lower_(k)) {
      v += kTwoPi;
    }
    if (v < lower_(k) - 1e-9 || v > upper_(k) + 1e-9) return std::nullopt;
    out(k) = v;
  }
  return out;
}

std::optional<JointVector> ArmKinematics::solve(const Eigen::Isometry3d& world_T_tcp, const JointVector& seed,
                                                const IkOptions& options) const {
  checkJoints(seed, "seed");
  const KDL::Frame goal = toKdl(world_from_base_.inverse() * world_T_tcp);
  std::mt19937 rng(options.random_seed);
  std::uniform_real_distribution<double> any_angle(-kPi, kPi);
  std::uniform_real_distribution<double> half_turn(0.1, kPi - 0.1);

  std::optional<JointVector> best;
  double best_cost = std::numeric_limits<double>::infinity();
  int found = 0;
  KDL::JntArray init(6);
  KDL::JntArray out(6);
  std::lock_guard<std::mutex> lock(ik_mutex_);
  for (int attempt = 0; attempt <= options.max_restarts; ++attempt) {
    if (attempt == 0) {
      init.data = seed;
    } else {
      for (int k = 0; k < 6; ++k) init(k) = any_angle(rng);
      if (options.require_branch) {  // restart inside the wanted wrist and elbow half-turns
        init(2) = branch_.elbow * half_turn(rng);
        init(4) = branch_.wrist * half_turn(rng);
      }
    }
    ik_solver_->CartToJnt(init, goal, out);  // the result is verified below whatever the return code
    if (!out.data.allFinite()) continue;
    const std::optional<JointVector> q = shiftTowards(out.data, seed);
    if (!q) continue;
    const Eigen::Isometry3d reached = fk(*q);
    if (positionError(reached, world_T_tcp) > options.position_tolerance ||
        rotationError(reached, world_T_tcp) > options.rotation_tolerance) {
      continue;
    }
    if (options.require_branch) {
      if (!isOnBranch(*q, branch_)) continue;
      return q;  // unique on the branch up to the 2 pi shifts already chosen
    }
    const JointVector d = (*q - seed).cwiseAbs();
    const double cost = d.maxCoeff() * 10.0 + d.sum();  // as pg_core.ur_ik.closest
    if (cost < best_cost) {
      best_cost = cost;
      best = q;
    }
    if (++found >= options.max_solutions) break;
  }
  return best;
}

std::optional<JointVector> ArmKinematics::solveDown(const Eigen::Vector3d& position, double yaw,
                                                    const JointVector& seed, const IkOptions& options) const {
  return solve(toolDownPose(position, yaw), seed, options);
}

}  // namespace pg_control
