#!/usr/bin/env python3
"""Acceptance of the ROS stack in simulation (sim.launch): grasp_target on a packed and an easy scene, truthful
answers against the simulator's ground truth, and bad input (unknown colour, absent target, busy, dead camera)
answered with a clear error while the node keeps serving."""

from __future__ import annotations

import subprocess
import time
import unittest

import rospy
import rostest
from pg_msgs.srv import GraspTarget, Infer, ResetScene
from pg_rostest import STACK_TIMEOUT_S, Call, fresh_scene_state, scene_state, wait_service

BUDGET_S = 400.0


class SimStack(unittest.TestCase):
    @classmethod
    def setUpClass(cls) -> None:
        rospy.init_node("rt_sim_stack")
        for name in ("/pg/grasp_target", "/pg/infer", "/pg/execute_primitive", "/pg_sim/reset_scene"):
            wait_service(name, STACK_TIMEOUT_S)
        cls.grasp = rospy.ServiceProxy("/pg/grasp_target", GraspTarget)
        cls.infer = rospy.ServiceProxy("/pg/infer", Infer)
        cls.reset = rospy.ServiceProxy("/pg_sim/reset_scene", ResetScene)

    def assertTruthful(self, res) -> None:
        truth = fresh_scene_state(rospy.get_time())
        self.assertEqual(res.success, not truth.target_in_workspace, f"{res.message}; scene: {truth.scene}")
        self.assertEqual(len(res.decisions), res.grasps + res.pushes + sum(not d.success for d in res.decisions))

    def test_1_bad_input_is_refused_and_nothing_moves(self) -> None:
        before = scene_state()
        res = self.grasp(target="mauve")
        self.assertFalse(res.success)
        self.assertIn("unknown target colour 'mauve'", res.message)
        colours = {o.color_name for o in before.objects}
        absent = next(c for c in ("purple", "pink", "cyan", "brown", "orange", "yellow", "red", "blue")
                      if c not in colours)
        res = self.grasp(target=absent)
        self.assertFalse(res.success)
        self.assertIn("not visible", res.message)
        self.assertEqual(res.grasps + res.pushes, 0)
        inf = self.infer(target="green")
        self.assertTrue(inf.success, inf.message)
        self.assertFalse(inf.decision.executed)

    def test_2_packed_scene_within_budget_and_busy(self) -> None:
        first = Call(self.grasp, target="green", timeout=BUDGET_S)
        t0 = time.monotonic()
        first.start()
        time.sleep(2.0)
        second = self.grasp(target="green")
        self.assertFalse(second.success)
        self.assertIn("busy", second.message)
        first.join(BUDGET_S + 60.0)
        self.assertFalse(first.is_alive(), "grasp_target did not return within its budget")
        self.assertIsNone(first.error)
        res = first.result
        rospy.loginfo("packed: %s %s grasps %d pushes %d in %.1f s", res.success, res.message, res.grasps,
                      res.pushes, time.monotonic() - t0)
        self.assertLess(time.monotonic() - t0, BUDGET_S + 60.0)
        self.assertTruthful(res)

    def test_3_easy_scene_succeeds(self) -> None:
        reset = self.reset(scene="household/case11")
        self.assertTrue(reset.success, reset.message)
        res = self.grasp(target="green", timeout=BUDGET_S)
        rospy.loginfo("easy: %s %s grasps %d pushes %d", res.success, res.message, res.grasps, res.pushes)
        self.assertTrue(res.success, res.message)
        self.assertGreaterEqual(res.grasps, 1)
        self.assertTrue(res.decisions[-1].target_grasped)
        self.assertTruthful(res)

    def test_9_dead_camera_is_a_clear_error(self) -> None:
        reset = self.reset(scene="household/case11")
        self.assertTrue(reset.success, reset.message)
        subprocess.run(["rosnode", "kill", "/heightmap_projector"], check=True, capture_output=True, timeout=30)
        time.sleep(1.0)
        for _ in range(2):  # the node keeps serving after the error
            t0 = time.monotonic()
            res = self.grasp(target="green")
            self.assertFalse(res.success)
            self.assertIn("no new heightmap", res.message)
            self.assertLess(time.monotonic() - t0, 15.0)
        inf = self.infer(target="green")
        self.assertFalse(inf.success)
        self.assertIn("no new heightmap", inf.message)


    def test_4_action_feedback_and_cancel(self) -> None:
        import actionlib
        from actionlib_msgs.msg import GoalStatus
        from pg_msgs.msg import GraspTargetAction, GraspTargetGoal

        client = actionlib.SimpleActionClient("/pg/grasp_target_action", GraspTargetAction)
        self.assertTrue(client.wait_for_server(rospy.Duration(30.0)))
        reset = self.reset(scene="packed/case01")
        self.assertTrue(reset.success, reset.message)
        feedback = []
        client.send_goal(GraspTargetGoal(target="green"), feedback_cb=feedback.append)
        deadline = time.monotonic() + 120.0
        while not feedback and time.monotonic() < deadline:
            time.sleep(0.1)
        self.assertTrue(feedback, "no feedback after the first action")
        self.assertTrue(feedback[0].last.executed)
        client.cancel_goal()
        self.assertTrue(client.wait_for_result(rospy.Duration(120.0)))
        result, state = client.get_result(), client.get_state()
        if state == GoalStatus.SUCCEEDED:  # the action that was running when cancelled grasped the target
            self.assertTrue(result.success)
        else:
            self.assertEqual(state, GoalStatus.PREEMPTED, result.message)
            self.assertEqual(result.message, "cancelled")
            # one feedback per executed decision, in order; feedback and result travel on different topics, and
            # actionlib's client drops a feedback that arrives after the result, so the last one may be missing
            settle = time.monotonic() + 10.0
            while len(feedback) < len(result.decisions) and time.monotonic() < settle:
                time.sleep(0.1)
            self.assertIn(len(feedback), (len(result.decisions) - 1, len(result.decisions)))
            for got, want in zip(feedback, result.decisions, strict=False):
                self.assertEqual((got.last.primitive, got.last.row, got.last.col), (want.primitive, want.row, want.col))
        self.assertFalse(self.grasp(target="mauve").success)  # the node serves again


if __name__ == "__main__":
    rostest.rosrun("pg_tests", "sim_stack", SimStack)
