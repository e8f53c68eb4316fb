#!/usr/bin/env python3
"""robot.launch's runtime without the simulator (tests/ros/robot_without_sim.launch, run by
tests/test_runtime_without_sim.py with tests/without_sim first on PYTHONPATH: no process of the run, this one
included, can import pybullet, pg_sim or pg_learning): from the recorded camera topics of a bag, the heightmap
projector publishes heightmaps and the policy node (the shipped lite model) answers /pg/infer with a decision on the
target."""

from __future__ import annotations

import importlib
import unittest

import rospy
import rostest
from pg_msgs.msg import Decision, Heightmap
from pg_msgs.srv import Infer
from pg_rostest import STACK_TIMEOUT_S, wait_service


class RobotWithoutSim(unittest.TestCase):
    @classmethod
    def setUpClass(cls) -> None:
        rospy.init_node("rt_robot_without_sim")

    def test_this_run_has_no_simulator(self) -> None:
        for name in ("pybullet", "pybullet_data", "pg_sim", "pg_learning"):
            with self.assertRaises(ImportError, msg=name):
                importlib.import_module(name)

    def test_the_policy_node_decides_on_the_recorded_images(self) -> None:
        wait_service("/pg/infer", STACK_TIMEOUT_S)
        hm = rospy.wait_for_message("/pg/heightmap", Heightmap, timeout=60.0)
        self.assertEqual((hm.header.frame_id, hm.color.height, hm.color.width), ("world", 224, 224))
        res = rospy.ServiceProxy("/pg/infer", Infer)(target="green")
        self.assertTrue(res.success, res.message)
        d = res.decision
        self.assertIn(d.primitive, (Decision.GRASP, Decision.PUSH))
        self.assertGreater(d.target_pixels, 100)
        self.assertTrue(0 <= d.row < 224 and 0 <= d.col < 224 and 0 <= d.rotation < 16, d)
        self.assertIn("lite", d.policy)


if __name__ == "__main__":
    rostest.rosrun("pg_tests", "robot_without_sim", RobotWithoutSim)
