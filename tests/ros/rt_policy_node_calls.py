#!/usr/bin/env python3
"""/pg/grasp_target's limits and endings against the simulated stack: NaN, infinite or negative limits are refused
with the field's name and nothing moves; `timeout` is wall-clock seconds and reported as given; a successful
/pg_sim/reset_scene while a call runs ends that call with "the scene was reset during the call"."""

from __future__ import annotations

import math
import time
import unittest

import rospy
import rostest
from pg_msgs.srv import GraspTarget, ResetScene
from pg_rostest import STACK_TIMEOUT_S, Call, wait_service

RESET = "the scene was reset during the call"


class PolicyNodeCalls(unittest.TestCase):
    @classmethod
    def setUpClass(cls) -> None:
        rospy.init_node("rt_policy_node_calls")
        for name in ("/pg/grasp_target", "/pg/execute_primitive", "/pg_sim/reset_scene"):
            wait_service(name, STACK_TIMEOUT_S)
        cls.grasp = rospy.ServiceProxy("/pg/grasp_target", GraspTarget)
        cls.reset = rospy.ServiceProxy("/pg_sim/reset_scene", ResetScene)

    def test_1_limits_out_of_range_name_the_field(self) -> None:
        cases = [({"timeout": math.nan}, "timeout"), ({"timeout": math.inf}, "timeout"),
                 ({"timeout": -1.0}, "timeout"), ({"max_actions": -1}, "max_actions"),
                 ({"max_failed_grasps": -2}, "max_failed_grasps")]
        for fields, name in cases:
            res = self.grasp(target="green", **fields)
            self.assertFalse(res.success, fields)
            self.assertIn(f"{name} must be", res.message, fields)
            self.assertIn("nothing moved", res.message, fields)
            self.assertEqual((res.grasps, res.pushes, len(res.decisions)), (0, 0, 0), fields)

    def test_2_sub_second_budget_is_reported_as_given(self) -> None:
        reset = self.reset(scene="packed/case01")
        self.assertTrue(reset.success, reset.message)
        t0 = time.monotonic()
        res = self.grasp(target="green", timeout=0.5)
        rospy.loginfo("timeout 0.5: %s after %d actions, %.2f wall s", res.message, len(res.decisions), res.wall_time)
        self.assertEqual(res.message, "time budget of 0.5 s spent")
        self.assertGreaterEqual(len(res.decisions), 1)  # checked between actions: the first one always runs
        self.assertLess(res.wall_time, time.monotonic() - t0 + 0.1)

    def test_3_reset_between_primitives_ends_the_call(self) -> None:
        for _attempt in range(3):  # a call that ends by itself before a reset is accepted proves nothing: again
            reset = self.reset(scene="packed/case01")
            self.assertTrue(reset.success, reset.message)
            call = Call(self.grasp, target="green", max_actions=10)
            started = time.monotonic()
            call.start()
            time.sleep(1.0)
            accepted, sent = False, 0.0
            while call.is_alive() and not accepted:
                sent = time.monotonic()
                accepted = self.reset(scene="packed/case02").success  # refused while an arm moves
                if not accepted:
                    time.sleep(0.2)
            call.join(300.0)
            self.assertFalse(call.is_alive(), "grasp_target did not end after the reset")
            self.assertIsNone(call.error)
            rospy.loginfo("reset accepted %s: %s", accepted, call.result.message)
            if accepted and started + call.result.wall_time > sent:  # the call still ran when the reset came
                self.assertTrue(call.result.message.startswith(RESET), call.result.message)
                self.assertFalse(call.result.success)
                return
        self.fail("no reset was accepted while a call ran")


if __name__ == "__main__":
    rostest.rosrun("pg_tests", "policy_node_calls", PolicyNodeCalls)
