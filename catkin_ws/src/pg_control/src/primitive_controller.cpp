#include "primitive_controller.h"

#include <ros/package.h>
#include <std_msgs/Float64.h>
#include <tf2/exceptions.h>
#include <tf2_eigen/tf2_eigen.h>
#include <trajectory_msgs/JointTrajectory.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <stdexcept>

#include "pg_control/urdf_chain.h"
#include "pg_control/user_text.h"

namespace pg_control {
namespace {

// tf's reason for a failed lookup quotes the requested frame again: there it is cut to kTfQuoteChars (the refusal
// shows kEchoedChars of it already), and the whole reason to kTfReasonChars.
constexpr std::size_t kTfQuoteChars = 16;
constexpr std::size_t kTfReasonChars = 160;

std::string fmt(const char* format, double a, double b = 0.0, double c = 0.0) {
  char buf[200];
  std::snprintf(buf, sizeof(buf), format, a, b, c);
  return buf;
}

// Private parameter with a default, logged so a run shows what it used.
template <typename T>
T param(ros::NodeHandle& pnh, const std::string& name, const T& fallback) {
  T value;
  pnh.param<T>(name, value, fallback);
  return value;
}

}  // namespace

PrimitiveController::PrimitiveController(ros::NodeHandle& nh, ros::NodeHandle& pnh)
    : nh_(nh), tf_listener_(tf_buffer_) {
  std::string config_path = param<std::string>(pnh, "workspace_config", "");
  if (config_path.empty()) {
    const std::string pkg = ros::package::getPath("pg_description");
    if (pkg.empty()) throw std::runtime_error("~workspace_config not set and package pg_description not found");
    config_path = pkg + "/config/workspace.yaml";
  }
  config_ = std::make_unique<pg_core::WorkspaceConfig>(pg_core::WorkspaceConfig::fromFile(config_path));

  UrdfModelPtr model;
  const std::string description_param = param<std::string>(pnh, "robot_description_param", "robot_description");
  std::string found;
  std::string xml;
  if (nh.searchParam(description_param, found) && nh.getParam(found, xml) && !xml.empty()) {
    model = parseUrdf(xml, "parameter " + found);
    ROS_INFO("primitive_controller: robot from parameter %s", found.c_str());
  } else {
    model = loadUrdfFile(config_->robot().urdf_path);
    ROS_INFO("primitive_controller: robot from %s", config_->robot().urdf_path.c_str());
  }
  planner_ = std::make_unique<PrimitivePlanner>(*config_, *model);

  world_frame_ = param<std::string>(pnh, "world_frame", "world");
  joint_states_topic_ = param<std::string>(pnh, "joint_states_topic", "/joint_states");
  goal_tolerance_ = param(pnh, "goal_tolerance", goal_tolerance_);
  goal_time_tolerance_ = param(pnh, "goal_time_tolerance", goal_time_tolerance_);
  timeout_limits_.default_timeout = param(pnh, "default_timeout", config_->primitives().time_budget);
  timeout_limits_.max_timeout = param(pnh, "max_timeout", timeout_limits_.max_timeout);
  home_timeout_ = param(pnh, "home_timeout", config_->primitives().time_budget);
  joint_states_timeout_ = param(pnh, "joint_states_timeout", joint_states_timeout_);
  clock_timeout_ = param(pnh, "clock_timeout", clock_timeout_);
  tf_timeout_ = param(pnh, "tf_timeout", tf_timeout_);
  max_wall_time_ = param(pnh, "max_wall_time", max_wall_time_);
  gripper_tolerance_ = param(pnh, "gripper_tolerance", gripper_tolerance_);
  gripper_stall_epsilon_ = param(pnh, "gripper_stall_epsilon", gripper_stall_epsilon_);
  gripper_stall_time_ = param(pnh, "gripper_stall_time", gripper_stall_time_);
  gripper_timeout_ = param(pnh, "gripper_timeout", gripper_timeout_);
  // Every time parameter becomes a ros::Duration: refuse to start rather than fail on each request.
  checkTimeoutLimits(timeout_limits_);
  checkSecondsParameter("goal_time_tolerance", goal_time_tolerance_, true);
  for (const auto& [name, value] : {std::pair<const char*, double>{"home_timeout", home_timeout_},
                                    {"joint_states_timeout", joint_states_timeout_},
                                    {"clock_timeout", clock_timeout_},
                                    {"tf_timeout", tf_timeout_},
                                    {"max_wall_time", max_wall_time_},
                                    {"gripper_stall_time", gripper_stall_time_},
                                    {"gripper_timeout", gripper_timeout_}}) {
    checkSecondsParameter(name, value);
  }

  for (const std::string& arm : planner_->armNames()) {
    ArmIo io;
    io.trajectory_topic =
        param<std::string>(pnh, arm + "/trajectory_topic", "/" + arm + "/scaled_pos_joint_traj_controller/command");
    io.gripper_topic = param<std::string>(pnh, arm + "/gripper_topic", "/" + arm + "/gripper/command");
    io.trajectory = nh.advertise<trajectory_msgs::JointTrajectory>(io.trajectory_topic, 1);
    io.gripper = nh.advertise<std_msgs::Float64>(io.gripper_topic, 1);
    io.finger_joints = {arm + "_gripper_finger1_joint", arm + "_gripper_finger2_joint"};
    io_[arm] = io;
  }

  ros::SubscribeOptions opts = ros::SubscribeOptions::create<sensor_msgs::JointState>(
      joint_states_topic_, 10, [this](const sensor_msgs::JointState::ConstPtr& m) { joints_.update(m); },
      ros::VoidPtr(), &state_queue_);
  joint_sub_ = nh.subscribe(opts);
  state_spinner_ = std::make_unique<ros::AsyncSpinner>(1, &state_queue_);
  state_spinner_->start();
  service_ = nh.advertiseService("/pg/execute_primitive", &PrimitiveController::onExecute, this);
  ROS_INFO("primitive_controller: serving /pg/execute_primitive (config %s)", config_path.c_str());
}

bool PrimitiveController::onExecute(pg_msgs::ExecutePrimitive::Request& req, pg_msgs::ExecutePrimitive::Response& res) {
  if (busy_.exchange(true)) {  // refused, not queued
    ROS_WARN("primitive_controller: refused a request while busy");
    res.success = false;
    res.grasped = false;
    res.arm = "";
    res.message = "busy";
    return true;
  }
  try {
    request_wall_deadline_ = ros::WallTime::now() + ros::WallDuration(max_wall_time_);
    execute(req, res);
  } catch (const std::exception& e) {  // never leave the service without an answer
    res.success = false;
    res.message = std::string("internal error: ") + e.what();
    if (res.arm.empty()) res.message += "; nothing moved";  // res.arm is set just before the first command
  }
  ROS_INFO("primitive_controller: %s -> success=%d grasped=%d arm='%s': %s",
           req.primitive == req.GRASP ? "grasp" : "push", res.success, res.grasped, res.arm.c_str(),
           res.message.c_str());
  busy_ = false;
  return true;
}

void PrimitiveController::execute(const pg_msgs::ExecutePrimitive::Request& req,
                                  pg_msgs::ExecutePrimitive::Response& res) {
  // Every return before `res.arm = plan.arm` below is a refusal: nothing commanded, arm "".
  res.success = false;
  res.grasped = false;
  res.arm = "";
  if (req.primitive != req.PUSH && req.primitive != req.GRASP) {
    res.message = "unknown primitive " + std::to_string(req.primitive) + " (0 = PUSH, 1 = GRASP); nothing moved";
    return;
  }
  double timeout = 0.0;  // s, ROS time, the steps before the return home
  try {
    timeout = resolveTimeout(req.timeout, timeout_limits_);
    checkFinite("position.point.x", req.position.point.x);
    checkFinite("position.point.y", req.position.point.y);
    checkFinite("position.point.z", req.position.point.z);
    checkFinite("yaw", req.yaw);
    checkDeadline(req.deadline, ros::WallTime::now().toSec());  // taken up after its caller gave up: never start
  } catch (const PrimitiveRefused& e) {
    res.message = e.what();
    return;
  }
  const std::string dead = checkAlive();
  if (!dead.empty()) {
    res.message = dead + "; nothing moved";
    return;
  }
  PrimitiveRequest request;
  request.type = req.primitive == req.GRASP ? PrimitiveType::kGrasp : PrimitiveType::kPush;
  request.yaw = req.yaw;
  request.arm = req.arm;
  const std::string tf_error = toWorld(req.position, &request.position);
  if (!tf_error.empty()) {
    res.message = tf_error + "; nothing moved";
    return;
  }

  std::map<std::string, JointVector> current;
  for (const std::string& arm : planner_->armNames()) {
    const auto q = joints_.positions(planner_->arm(arm).jointNames());
    if (q) current[arm] = *q;
  }
  PrimitivePlan plan;
  try {
    plan = planner_->plan(request, current);
  } catch (const PrimitiveRefused& e) {
    res.message = e.what();
    return;
  } catch (const std::invalid_argument& e) {
    res.message = std::string("/joint_states lacks an arm's joints: ") + e.what() + "; nothing moved";
    return;
  }
  double planned = 0.0;  // the return home has its own budget (~home_timeout)
  for (const PrimitiveStep& step : plan.steps) {
    if (step.kind == PrimitiveStep::Kind::kMove && step.name != "home") planned += step.motion.duration();
  }
  if (planned > timeout) {
    res.message = "the planned motion takes " + formatSeconds(planned) + ", more than the timeout of " +
                  formatSeconds(timeout) + "; nothing moved";
    return;
  }
  const ArmIo& io = io_.at(plan.arm);
  for (const ros::Publisher* pub : {&io.trajectory, &io.gripper}) {
    if (pub->getNumSubscribers() == 0) {
      res.message = "no subscriber on " + pub->getTopic() + " (is the arm's controller running?); nothing moved";
      return;
    }
  }

  try {  // again just before the first command: the tf wait and the planning took time
    checkDeadline(req.deadline, ros::WallTime::now().toSec());
  } catch (const PrimitiveRefused& e) {
    res.message = e.what();
    return;
  }
  const Deadline limit = deadlineIn(timeout, "the primitive");
  res.arm = plan.arm;
  std::string error;
  std::string outcome = request.type == PrimitiveType::kGrasp ? "grasped" : "pushed";
  for (const PrimitiveStep& step : plan.steps) {
    if (step.name == "home") break;  // planned again from the actual joints below
    if (step.kind == PrimitiveStep::Kind::kMove) {
      error = runMove(plan.arm, step.name, step.motion, limit);
    } else if (step.kind == PrimitiveStep::Kind::kGripper) {
      error = runGripper(plan.arm, step.opening, step.wait, limit);
    } else {
      const std::optional<double> now = opening(plan.arm);
      res.grasped = now && *now > config_->gripper().closed_threshold;
      if (!res.grasped) {
        outcome = "nothing grasped: fingers closed";
        // release at the lift pose: what the closed jaw snagged falls back at the grasp site (as pg_sim)
        error = runGripper(plan.arm, config_->gripper().max_opening, true, limit);
      }
    }
    if (!error.empty()) {
      error = "'" + step.name + "' failed: " + error;
      break;
    }
  }
  const std::string home_error = goHome(plan.arm);
  res.success = error.empty() && home_error.empty();
  res.message = error.empty() ? outcome : error;
  if (!home_error.empty()) res.message += "; return home failed: " + home_error;
}

std::string PrimitiveController::checkAlive() const {
  const double age = joints_.secondsSinceLast();
  if (age > joint_states_timeout_) {
    return std::isinf(age) ? "no message on " + joint_states_topic_ + " yet (robot driver or simulator not running?)"
                           : "no message on " + joint_states_topic_ + " for " + formatSeconds(age) +
                                 " (robot driver or simulator dead?)";
  }
  return "";
}

std::string PrimitiveController::toWorld(const geometry_msgs::PointStamped& point, Eigen::Vector3d* out) const {
  const Eigen::Vector3d p(point.point.x, point.point.y, point.point.z);
  const std::string& frame = point.header.frame_id;
  if (frame.empty()) return "position.header.frame_id is empty (give the frame, e.g. '" + world_frame_ + "')";
  if (frame == world_frame_ || frame == "/" + world_frame_) {
    *out = p;
    return "";
  }
  const ros::WallTime give_up = ros::WallTime::now() + ros::WallDuration(tf_timeout_);
  std::string why;
  while (ros::ok()) {
    try {
      *out = tf2::transformToEigen(tf_buffer_.lookupTransform(world_frame_, frame, point.header.stamp)) * p;
      return "";
    } catch (const tf2::TransformException& e) {
      why = e.what();
    }
    if (ros::WallTime::now() > give_up) break;
    ros::WallDuration(0.01).sleep();
  }
  return "no transform from '" + cutUserText(frame) + "' to '" + world_frame_ + "' within " +
         formatSeconds(tf_timeout_) + ": " + cutUserText(cutUserTextIn(why, frame, kTfQuoteChars), kTfReasonChars);
}

PrimitiveController::Deadline PrimitiveController::deadlineIn(double ros_seconds, const std::string& whose) const {
  return Deadline{ros::Time::now() + ros::Duration(ros_seconds), request_wall_deadline_,
                  describeTimeout(whose, ros_seconds)};
}

std::string PrimitiveController::waitUntil(const std::function<bool()>& done, const Deadline& limit,
                                           const std::string& what) const {
  ros::Time last_ros = ros::Time::now();
  ros::WallTime last_tick = ros::WallTime::now();
  for (;;) {
    if (done()) return "";
    if (!ros::ok()) return "node shutting down";
    const std::string dead = checkAlive();
    if (!dead.empty()) return dead;
    const ros::Time now = ros::Time::now();
    const ros::WallTime wall = ros::WallTime::now();
    if (now != last_ros) {
      last_ros = now;
      last_tick = wall;
    } else if ((wall - last_tick).toSec() > clock_timeout_) {
      return "ROS time has not advanced for " + formatSeconds(clock_timeout_) + " (is /clock published?)";
    }
    if (now > limit.ros) return what + " did not finish within " + limit.ros_what;
    if (wall > limit.wall) {
      return what + " exceeded the wall-clock limit of " + formatSeconds(max_wall_time_) + " (~max_wall_time)";
    }
    ros::WallDuration(poll_period_).sleep();
  }
}

std::optional<double> PrimitiveController::opening(const std::string& arm) const {
  const auto q = joints_.positions(io_.at(arm).finger_joints);
  if (!q) return std::nullopt;
  return q->sum();
}

std::string PrimitiveController::runMove(const std::string& arm, const std::string& step, const TimedPath& path,
                                         const Deadline& limit) {
  const ArmKinematics& kin = planner_->arm(arm);
  trajectory_msgs::JointTrajectory msg;
  msg.header.stamp = ros::Time(0);  // start on receipt
  msg.joint_names = kin.jointNames();
  for (std::size_t k = 0; k < path.positions.size(); ++k) {
    trajectory_msgs::JointTrajectoryPoint pt;
    pt.positions.assign(path.positions[k].data(), path.positions[k].data() + path.positions[k].size());
    pt.velocities.assign(path.velocities[k].data(), path.velocities[k].data() + path.velocities[k].size());
    pt.time_from_start = ros::Duration(path.times[k]);
    msg.points.push_back(pt);
  }
  const ros::Time start = ros::Time::now();
  io_.at(arm).trajectory.publish(msg);

  const JointVector goal = path.positions.back();
  double error = 0.0;
  const auto reached = [&]() {
    const auto q = joints_.positions(kin.jointNames());
    if (!q) return false;
    error = (*q - goal).cwiseAbs().maxCoeff();
    return ros::Time::now() >= start + ros::Duration(path.duration()) && error <= goal_tolerance_;
  };
  // The move ends at the earlier of the caller's deadline and its own planned duration plus goal_time_tolerance.
  Deadline move_limit = limit;
  const ros::Time planned_end = start + ros::Duration(path.duration() + goal_time_tolerance_);
  const bool own_limit = planned_end < limit.ros;
  if (own_limit) {
    move_limit.ros = planned_end;
    move_limit.ros_what = describeMoveLimit(path.duration(), goal_time_tolerance_);
  }
  const std::string why = waitUntil(reached, move_limit, "arm motion '" + step + "'");
  if (why.empty() || !checkAlive().empty()) return why;  // a dead /joint_states says it all
  const std::string planned = own_limit ? "" : "planned " + formatSeconds(path.duration()) + ", ";
  return why + " (" + planned + fmt("final joint error %.4f rad, goal_tolerance %.4f rad)", error, goal_tolerance_);
}

std::string PrimitiveController::runGripper(const std::string& arm, double opening_m, bool wait,
                                            const Deadline& limit) {
  const double target = std::clamp(opening_m, 0.0, config_->gripper().max_opening);
  std_msgs::Float64 msg;
  msg.data = target;
  io_.at(arm).gripper.publish(msg);
  if (!wait) return "";
  const ros::Time start = ros::Time::now();
  std::optional<double> reference = opening(arm);  // last opening that counted as movement
  ros::Time moved = start;
  const auto settled = [&]() {
    const std::optional<double> now = opening(arm);
    if (!now) return false;
    const ros::Time t = ros::Time::now();
    if (std::abs(*now - target) < gripper_tolerance_) return true;  // reached
    if (!reference || std::abs(*now - *reference) > gripper_stall_epsilon_) {
      reference = now;
      moved = t;
    }
    if ((t - moved).toSec() >= gripper_stall_time_) return true;  // stalled (on an object)
    return (t - start).toSec() >= gripper_timeout_;               // as pg_sim: go on after the time limit
  };
  const std::string why = waitUntil(settled, limit, "gripper");
  if (why.empty()) return "";
  if (!opening(arm)) return "/joint_states lacks " + io_.at(arm).finger_joints.front() + ": " + why;
  return why;
}

std::string PrimitiveController::goHome(const std::string& arm) {
  const std::string dead = checkAlive();
  if (!dead.empty()) return dead;
  std::string missing;
  const auto q = joints_.positions(planner_->arm(arm).jointNames(), &missing);
  if (!q) return "/joint_states lacks " + missing;
  const TimedPath path = planner_->jointMove(arm, *q, planner_->home(arm));
  const Deadline limit =
      deadlineIn(std::max(home_timeout_, path.duration() + goal_time_tolerance_ + 1.0), "the return home");
  std::string error = runMove(arm, "home", path, limit);
  if (error.empty()) error = runGripper(arm, config_->gripper().max_opening, true, limit);  // releases held objects
  return error;
}

}  // namespace pg_control
