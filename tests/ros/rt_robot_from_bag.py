#!/usr/bin/env python3
"""robot.launch with the camera and arm topics from a rosbag instead of hardware (no simulator node): the bag is
written here from the ROS-free simulator core (pg_rostest.write_robot_bag: camera topics, one JointState topic per arm
as two ur_robot_drivers publish them), played with --clock, and the real-robot bringup must give tf, /pg/heightmap,
the controller service and a policy decision, exactly the interface the simulated cell gives."""

from __future__ import annotations

import subprocess
import tempfile
import time
import unittest
from pathlib import Path

import rosbag
import rospy
import rostest
import tf2_ros
from pg_msgs.msg import Heightmap
from pg_msgs.srv import Infer
from pg_rostest import STACK_TIMEOUT_S, wait_service, write_robot_bag
from sensor_msgs.msg import JointState


class RobotFromBag(unittest.TestCase):
    def test_robot_bringup_runs_on_recorded_topics(self) -> None:
        rospy.init_node("rt_robot_from_bag")
        bag = Path(tempfile.mkdtemp()) / "robot_inputs.bag"
        write_robot_bag(bag)
        with rosbag.Bag(str(bag)) as b:
            topics = set(b.get_type_and_topic_info().topics)
        self.assertIn("/camera/depth/color/points", topics)
        self.assertIn("/left/joint_states", topics)
        player = subprocess.Popen(["rosbag", "play", "--clock", "-l", "-q", str(bag)])
        try:
            wait_service("/pg/infer", STACK_TIMEOUT_S)
            wait_service("/pg/execute_primitive", STACK_TIMEOUT_S)
            hm = rospy.wait_for_message("/pg/heightmap", Heightmap, timeout=60.0)
            self.assertEqual(hm.header.frame_id, "world")
            self.assertEqual((hm.color.height, hm.color.width), (224, 224))
            # the merger leaves out a source older than its max_age (the bag loops, the clock jumps back): within
            # 30 s a message must carry both arms' 12 joints
            deadline = time.monotonic() + 30.0
            arm_joints = 0
            while arm_joints != 12 and time.monotonic() < deadline:
                js = rospy.wait_for_message("/joint_states", JointState, timeout=max(0.1, deadline - time.monotonic()))
                arm_joints = len([n for n in js.name if n.endswith("_joint") and "gripper" not in n])
            self.assertEqual(arm_joints, 12)
            buf = tf2_ros.Buffer()
            tf2_ros.TransformListener(buf)
            for child in ("left_tool0", "right_gripper_tcp", "camera_color_optical_frame"):
                buf.lookup_transform("world", child, rospy.Time(0), rospy.Duration(20.0))
            res = rospy.ServiceProxy("/pg/infer", Infer)(target="green")
            self.assertTrue(res.success, res.message)
            self.assertGreater(res.decision.target_pixels, 100)
        finally:
            player.terminate()
            player.wait(10)


if __name__ == "__main__":
    rostest.rosrun("pg_tests", "robot_from_bag", RobotFromBag)
