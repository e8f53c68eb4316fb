#include "pg_control/primitive_planner.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <optional>
#include <utility>

#include "pg_control/cartesian_path.h"
#include "pg_control/primitive_limits.h"
#include "pg_control/user_text.h"

namespace pg_control {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kMaxJointJump = 0.5;  // rad between Cartesian waypoints, as pg_sim

std::string fmt(const char* format, double a, double b, double c) {
  char buf[160];
  std::snprintf(buf, sizeof(buf), format, a, b, c);
  return buf;
}

std::string interval(const pg_core::Interval& i) { return fmt("[%g, %g]", i.min, i.max, 0.0); }

PrimitiveStep gripperStep(const std::string& name, double opening, bool wait) {
  PrimitiveStep s;
  s.kind = PrimitiveStep::Kind::kGripper;
  s.name = name;
  s.opening = opening;
  s.wait = wait;
  return s;
}

PrimitiveStep moveStep(const std::string& name, TimedPath motion, std::vector<Eigen::Vector3d> tcp_points = {}) {
  PrimitiveStep s;
  s.kind = PrimitiveStep::Kind::kMove;
  s.name = name;
  s.motion = std::move(motion);
  s.tcp_points = std::move(tcp_points);
  return s;
}

}  // namespace

const char* toString(PrimitiveType type) { return type == PrimitiveType::kGrasp ? "grasp" : "push"; }

double PrimitivePlan::motionDuration() const {
  double sum = 0.0;
  for (const auto& s : steps) {
    if (s.kind == PrimitiveStep::Kind::kMove) sum += s.motion.duration();
  }
  return sum;
}

PrimitivePlanner::PrimitivePlanner(const pg_core::WorkspaceConfig& config, const urdf::ModelInterface& model)
    : config_(config) {
  for (const pg_core::ArmSpec& spec : config_.robot().arms) {
    arms_[spec.name] = std::make_unique<ArmKinematics>(model, "world", spec, config_.robot());
  }
}

std::vector<std::string> PrimitivePlanner::armNames() const {
  std::vector<std::string> names;
  for (const pg_core::ArmSpec& spec : config_.robot().arms) names.push_back(spec.name);
  return names;
}

const ArmKinematics& PrimitivePlanner::arm(const std::string& name) const {
  const auto it = arms_.find(name);
  if (it == arms_.end()) throw std::invalid_argument("unknown arm '" + cutUserText(name) + "'");
  return *it->second;
}

TimingOptions PrimitivePlanner::timingOptions() const {
  TimingOptions t;
  t.joint_velocity_limit = config_.robot().joint_velocity_limit;
  for (const auto& kv : arms_) t.joint_velocity_limit = std::min(t.joint_velocity_limit, kv.second->velocityLimit());
  return t;
}

std::vector<std::string> PrimitivePlanner::armOrder(const std::string& arm, const Eigen::Vector2d& xy) const {
  if (!arm.empty()) {
    if (arms_.count(arm) == 0) {
      std::string known;
      for (const auto& n : armNames()) known += (known.empty() ? "" : ", ") + n;
      throw PrimitiveRefused("unknown arm '" + cutUserText(arm) + "' (known: " + known + "); nothing moved");
    }
    return {arm};
  }
  std::vector<std::pair<double, std::string>> by_distance;
  for (const pg_core::ArmSpec& spec : config_.robot().arms) {
    by_distance.emplace_back(std::hypot(spec.xyz[0] - xy.x(), spec.xyz[1] - xy.y()), spec.name);
  }
  std::stable_sort(by_distance.begin(), by_distance.end(),
                   [](const auto& a, const auto& b) { return a.first < b.first; });
  std::vector<std::string> order;
  for (const auto& d : by_distance) order.push_back(d.second);
  return order;
}

TimedPath PrimitivePlanner::jointMove(const std::string& name, const JointVector& from, const JointVector& to) const {
  const ArmKinematics& kin = arm(name);
  if (from.size() != 6 || to.size() != 6 || !from.allFinite() || !to.allFinite()) {
    throw std::invalid_argument("jointMove: need 6 finite joint angles at both ends");
  }
  if (!kin.withinLimits(to)) throw std::invalid_argument("jointMove: target outside the joint limits");
  return timeParameterize({from, to}, {}, 1.0, timingOptions());
}

void PrimitivePlanner::checkWorkspace(const std::vector<std::pair<std::string, Eigen::Vector3d>>& points) const {
  for (const auto& [what, p] : points) {
    if (!config_.contains(p.x(), p.y(), p.z())) {
      throw PrimitiveRefused(what + fmt(" (%.3f, %.3f, %.3f) m is outside the workspace", p.x(), p.y(), p.z()) + " x " +
                             interval(config_.xRange()) + " y " + interval(config_.yRange()) + " z " +
                             interval(config_.zRange()) + " (nothing moved)");
    }
  }
}

PrimitivePlan PrimitivePlanner::plan(const PrimitiveRequest& request,
                                     const std::map<std::string, JointVector>& current) const {
  checkFinite("position x (world)", request.position.x());
  checkFinite("position y (world)", request.position.y());
  checkFinite("position z (world)", request.position.z());
  checkFinite("yaw", request.yaw);
  const pg_core::PrimitiveParams& pr = config_.primitives();
  const Eigen::Vector3d up(0.0, 0.0, pr.approach_height);
  const Eigen::Vector3d point = request.position;
  const Eigen::Vector3d pre = point + up;
  const Eigen::Vector3d above(pre.x(), pre.y(), std::max(pr.transit_height, pre.z()));

  std::vector<std::vector<Eigen::Vector3d>> lines;
  if (request.type == PrimitiveType::kGrasp) {
    const Eigen::Vector3d lift = point + Eigen::Vector3d(0.0, 0.0, pr.lift_height);
    checkWorkspace({{"grasp point", point}, {"pre-grasp pose", pre}, {"lift pose", lift}});
    lines = {{above, pre, point}, {point, lift}};
  } else {
    checkWorkspace({{"push start", point}, {"pre-push pose", pre}});
    Eigen::Vector3d end = point + pr.push_length * Eigen::Vector3d(std::cos(request.yaw), std::sin(request.yaw), 0.0);
    end.x() = std::clamp(end.x(), config_.xRange().min, config_.xRange().max);  // as VPG: the end is clipped
    end.y() = std::clamp(end.y(), config_.yRange().min, config_.yRange().max);
    lines = {{above, pre, point}, {point, end}, {end, end + up}};
  }

  std::string reasons;
  std::string tried;
  for (const std::string& name : armOrder(request.arm, pre.head<2>())) {
    const auto it = current.find(name);
    if (it == current.end()) throw std::invalid_argument("no current joint angles for arm '" + name + "'");
    try {
      return planArm(name, request, lines, it->second);
    } catch (const PlanningError& e) {
      tried += (tried.empty() ? "" : ", ") + name;
      reasons += std::string("; ") + e.what();
    }
  }
  throw PrimitiveRefused(fmt("pose (%.3f, %.3f) yaw %.1f deg", pre.x(), pre.y(), request.yaw * 180.0 / kPi) +
                         " is unreachable by arm(s) " + tried +
                         " (no IK solution along the straight-line path; nothing moved)" + reasons);
}

PrimitivePlan PrimitivePlanner::planArm(const std::string& name, const PrimitiveRequest& request,
                                        const std::vector<std::vector<Eigen::Vector3d>>& lines,
                                        const JointVector& current) const {
  const ArmKinematics& kin = arm(name);
  if (current.size() != 6 || !current.allFinite()) {
    throw std::invalid_argument("current joints of arm '" + name + "' must be 6 finite numbers");
  }
  const pg_core::PrimitiveParams& pr = config_.primitives();
  const pg_core::GripperParams& g = config_.gripper();
  const TimingOptions timing = timingOptions();
  CartesianPathOptions path_options;
  path_options.step = pr.waypoint_step;
  path_options.max_jump = kMaxJointJump;

  // The transit target is solved from home (as pg_sim) so the branch and wrist turn are those of home.
  const std::optional<JointVector> q_above = kin.solveDown(lines[0][0], request.yaw, kin.home());
  if (!q_above) {
    throw PlanningError("arm '" + name + "': no IK solution on its branch at the transit pose" +
                        fmt(" (%.3f, %.3f, %.3f) m", lines[0][0].x(), lines[0][0].y(), lines[0][0].z()));
  }
  std::vector<CartesianPath> paths;
  JointVector q = *q_above;
  for (const auto& line : lines) {
    paths.push_back(planCartesianPath(kin, line, request.yaw, q, path_options));
    q = paths.back().joints.back();
  }
  const auto line = [&](const std::string& step_name, std::size_t i, double speed) {
    return moveStep(step_name, timeParameterize(paths[i].joints, paths[i].lengths, speed, timing), paths[i].points);
  };

  PrimitivePlan plan;
  plan.type = request.type;
  plan.arm = name;
  const bool grasp = request.type == PrimitiveType::kGrasp;
  plan.steps.push_back(gripperStep(grasp ? "open" : "close", grasp ? g.max_opening : 0.0, false));
  plan.steps.push_back(moveStep("transit", jointMove(name, current, *q_above)));
  plan.steps.push_back(line("approach", 0, pr.cartesian_speed));
  if (grasp) {
    plan.steps.push_back(gripperStep("close", 0.0, true));
    plan.steps.push_back(line("lift", 1, pr.cartesian_speed));
    PrimitiveStep check;
    check.kind = PrimitiveStep::Kind::kCheckGrasp;
    check.name = "check";
    plan.steps.push_back(check);
  } else {
    plan.steps.push_back(line("push", 1, pr.push_speed));
    plan.steps.push_back(line("retreat", 2, pr.cartesian_speed));
  }
  plan.steps.push_back(moveStep("home", jointMove(name, q, kin.home())));
  plan.steps.push_back(gripperStep("release", g.max_opening, true));
  return plan;
}

}  // namespace pg_control
