// primitive_controller's ROS side: serves /pg/execute_primitive by planning with pg_control_core and executing the
// plan on the arm trajectory controllers and grippers, watching /joint_states. Every wait is bounded by ROS time
// (the request's timeout; works with /use_sim_time and a sim faster than real time) and by wall-clock guards (dead
// /joint_states, stopped /clock, max_wall_time), so a call never hangs. A request is checked (primitive_limits.h)
// and planned before anything is commanded; the answer names an arm only once that arm has been commanded. A
// request whose wall-clock `deadline` has passed when it is taken up or when its first command is due (its caller
// gave up, e.g. while this process was stopped) is refused: an abandoned primitive never runs later.
#ifndef PG_CONTROL_PRIMITIVE_CONTROLLER_H
#define PG_CONTROL_PRIMITIVE_CONTROLLER_H

#include <pg_msgs/ExecutePrimitive.h>
#include <ros/callback_queue.h>
#include <ros/ros.h>
#include <tf2_ros/buffer.h>
#include <tf2_ros/transform_listener.h>

#include <atomic>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "joint_state_cache.h"
#include "pg_control/primitive_limits.h"
#include "pg_control/primitive_planner.h"

namespace pg_control {

class PrimitiveController {
 public:
  // Reads the private parameters (see primitive_controller_node.cpp), loads the config and the URDF, advertises the
  // service. Throws std::runtime_error when the config or URDF cannot be loaded.
  PrimitiveController(ros::NodeHandle& nh, ros::NodeHandle& pnh);

 private:
  struct ArmIo {
    std::string trajectory_topic;
    std::string gripper_topic;
    ros::Publisher trajectory;
    ros::Publisher gripper;
    std::vector<std::string> finger_joints;  // opening = sum of their positions (m)
  };
  // Limits of one wait: ROS-time deadline and wall-clock deadline.
  struct Deadline {
    ros::Time ros;
    ros::WallTime wall;
    std::string ros_what;  // what set `ros`, for "did not finish within ...": "the primitive's timeout of 8.00 s"
  };

  bool onExecute(pg_msgs::ExecutePrimitive::Request& req, pg_msgs::ExecutePrimitive::Response& res);
  void execute(const pg_msgs::ExecutePrimitive::Request& req, pg_msgs::ExecutePrimitive::Response& res);

  // Each returns "" on success, else the reason.
  std::string checkAlive() const;
  std::string toWorld(const geometry_msgs::PointStamped& point, Eigen::Vector3d* out) const;
  std::string runMove(const std::string& arm, const std::string& step, const TimedPath& path, const Deadline& limit);
  std::string runGripper(const std::string& arm, double opening, bool wait, const Deadline& limit);
  std::string goHome(const std::string& arm);
  std::string waitUntil(const std::function<bool()>& done, const Deadline& limit, const std::string& what) const;
  std::optional<double> opening(const std::string& arm) const;
  // ROS-time deadline `ros_seconds` (s) from now, described as `whose`'s timeout; the wall deadline of the request.
  Deadline deadlineIn(double ros_seconds, const std::string& whose) const;

  ros::NodeHandle nh_;
  std::unique_ptr<pg_core::WorkspaceConfig> config_;
  std::unique_ptr<PrimitivePlanner> planner_;
  std::map<std::string, ArmIo> io_;
  std::string world_frame_;
  std::string joint_states_topic_;

  // Parameters (seconds are ROS time unless marked wall).
  double goal_tolerance_ = 0.01;         // rad, final joint error accepted at the end of a move
  double goal_time_tolerance_ = 1.0;     // s a move may run past its planned duration
  TimeoutLimits timeout_limits_;         // s per primitive: the default (request gives 0) and the maximum accepted
  double home_timeout_ = 8.0;            // s for the return home
  double joint_states_timeout_ = 2.0;    // wall s without /joint_states = dead
  double clock_timeout_ = 2.0;           // wall s without ROS time advancing (sim time) = dead
  double tf_timeout_ = 1.0;              // wall s to wait for the request's transform
  double max_wall_time_ = 120.0;         // wall s any request may take in total
  double gripper_tolerance_ = 5e-4;      // m: the fingers reached the commanded opening
  double gripper_stall_epsilon_ = 2e-4;  // m: less change than this ...
  double gripper_stall_time_ = 0.2;      // ... for this long = stalled on an object
  double gripper_timeout_ = 2.0;         // s the fingers may move before the controller goes on
  double poll_period_ = 0.005;           // wall s between checks

  JointStateCache joints_;
  ros::CallbackQueue state_queue_;  // /joint_states flows on its own thread whatever the service threads do
  std::unique_ptr<ros::AsyncSpinner> state_spinner_;
  ros::Subscriber joint_sub_;
  tf2_ros::Buffer tf_buffer_;
  tf2_ros::TransformListener tf_listener_;
  ros::ServiceServer service_;
  std::atomic<bool> busy_{false};
  ros::WallTime request_wall_deadline_;
};

}  // namespace pg_control

#endif  // PG_CONTROL_PRIMITIVE_CONTROLLER_H
