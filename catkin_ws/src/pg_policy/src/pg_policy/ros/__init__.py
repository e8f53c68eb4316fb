"""ROS shells of pg_policy (rospy nodes and message conversions). The rest of pg_policy never imports ROS."""
