"""The per-trial budget of a grasp-the-target attempt (DESIGN.md section 8): shared by the policy node's loop and
the evaluation protocol, so that a ROS call and a protocol trial give up at the same point."""

DEFAULT_MAX_ACTIONS = 30  # actions (pushes and grasps) per attempt
DEFAULT_MAX_FAILED_GRASPS = 5  # failed grasps that end an attempt
