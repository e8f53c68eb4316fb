// primitive_controller: serves /pg/execute_primitive (pg_msgs/ExecutePrimitive) for the dual UR5e (DESIGN.md
// sections 4-5). Thin shell around pg_control_core (planning) and PrimitiveController (execution).
//
// Private parameters (defaults):
//   ~workspace_config        pg_policy's config/workspace.yaml      the shared geometry
//   ~robot_description_param "robot_description"                    URDF string parameter; when absent, the
//                                                                    config's robot.urdf file is loaded
//   ~world_frame             "world"
//   ~joint_states_topic      "/joint_states"
//   ~<arm>/trajectory_topic  "/<arm>/scaled_pos_joint_traj_controller/command"  (trajectory_msgs/JointTrajectory)
//   ~<arm>/gripper_topic     "/<arm>/gripper/command"               (std_msgs/Float64, opening in m)
//   ~goal_tolerance 0.01 rad, ~goal_time_tolerance 1.0 s, ~default_timeout and ~home_timeout
//   (primitives.time_budget), ~max_timeout 600 s (the largest request timeout accepted), ~joint_states_timeout
//   2.0 wall s, ~clock_timeout 2.0 wall s, ~tf_timeout 1.0 wall s, ~max_wall_time 120 wall s, ~gripper_tolerance
//   5e-4 m, ~gripper_stall_epsilon 2e-4 m, ~gripper_stall_time 0.2 s, ~gripper_timeout 2.0 s, ~service_threads 2
//   Every time parameter must be finite, > 0 (goal_time_tolerance >= 0) and at most 1e6 s, and default_timeout at
//   most max_timeout; otherwise the node exits at start with the parameter named.
#include <ros/ros.h>

#include <exception>
#include <memory>

#include "primitive_controller.h"

int main(int argc, char** argv) {
  ros::init(argc, argv, "primitive_controller");
  ros::NodeHandle nh;
  ros::NodeHandle pnh("~");
  std::unique_ptr<pg_control::PrimitiveController> controller;
  try {
    controller = std::make_unique<pg_control::PrimitiveController>(nh, pnh);
  } catch (const std::exception& e) {
    ROS_FATAL("primitive_controller: %s", e.what());
    return 1;
  }
  // The service callback blocks while a primitive runs: a second thread answers concurrent calls ("busy").
  int threads = 2;
  pnh.param("service_threads", threads, threads);
  ros::AsyncSpinner spinner(std::max(2, threads));
  spinner.start();
  ros::waitForShutdown();
  return 0;
}
