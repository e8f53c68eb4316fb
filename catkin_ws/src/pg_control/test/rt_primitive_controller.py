#!/usr/bin/env python3
"""rostest node of primitive_controller.test: /pg/execute_primitive against a fake dual arm.

The fake arm (fake_arms.FakeArms, the test fixture of the code around it) listens on both arms' trajectory and
gripper topics and publishes /joint_states. Checks: a grasp succeeds and reports the held object; published
trajectories respect the UR5e joint velocity limit; out-of-workspace points and unknown frames are refused with
nothing published; a second call while one runs answers "busy"; a silent /joint_states gives a clear error within
the timeout and the node keeps serving; NaN, negative, infinite and too large timeouts and non-finite positions or
yaws are refused with the field named and no arm; a move that overruns says which limit ended it (the primitive's
timeout or its planned duration plus goal_time_tolerance) and with what numbers; a request whose deadline has
passed, also one that waited in the stopped (SIGSTOP) controller until after it, is refused with nothing published.
"""

from __future__ import annotations

import math
import os
import re
import signal
import threading
import time
import unittest
import xmlrpc.client

import numpy as np
import rosgraph
import rospy
import rostest
import tf2_ros
from fake_arms import ARM_JOINTS, GEOMETRY, FakeArms
from geometry_msgs.msg import PointStamped, TransformStamped
from pg_msgs.srv import ExecutePrimitive, ExecutePrimitiveRequest

PKG = "pg_control"
SERVICE = "/pg/execute_primitive"
VMAX = GEOMETRY.robot.joint_velocity_limit
CALL_TIMEOUT_S = 60.0  # wall seconds any single call may take in these tests


def request(primitive: int, x: float, y: float, z: float, yaw: float = 0.0, frame: str = "world",
            arm: str = "", timeout: float = 0.0) -> ExecutePrimitiveRequest:
    req = ExecutePrimitiveRequest()
    req.primitive = primitive
    req.position = PointStamped()
    req.position.header.frame_id = frame
    req.position.point.x, req.position.point.y, req.position.point.z = x, y, z
    req.yaw = yaw
    req.arm = arm
    req.timeout = timeout
    return req


class Call(threading.Thread):
    """A service call in the background."""

    def __init__(self, proxy, req) -> None:
        super().__init__(daemon=True)
        self.proxy, self.req, self.result, self.error, self.seconds = proxy, req, None, None, None

    def run(self) -> None:
        start = time.monotonic()
        try:
            self.result = self.proxy(self.req)
        except Exception as exc:  # noqa: BLE001 (reported by the test)
            self.error = exc
        self.seconds = time.monotonic() - start


class TestPrimitiveController(unittest.TestCase):
    fake: FakeArms
    proxy: rospy.ServiceProxy

    @classmethod
    def setUpClass(cls) -> None:
        rospy.init_node("rt_primitive_controller")
        cls.fake = FakeArms()
        broadcaster = tf2_ros.StaticTransformBroadcaster()
        t = TransformStamped()  # `table_corner` = world translated by (-0.2, -0.2, 0)
        t.header.stamp = rospy.Time.now()
        t.header.frame_id, t.child_frame_id = "world", "table_corner"
        t.transform.translation.x = t.transform.translation.y = -0.2
        t.transform.rotation.w = 1.0
        broadcaster.sendTransform(t)
        cls.broadcaster = broadcaster
        rospy.wait_for_service(SERVICE, timeout=60.0)
        cls.proxy = rospy.ServiceProxy(SERVICE, ExecutePrimitive)
        deadline = time.monotonic() + 30.0  # the controller and the fake must be connected both ways
        while time.monotonic() < deadline and (cls.fake.pub.get_num_connections() == 0 or
                                               any(s.get_num_connections() == 0 for s in cls.fake.subs)):
            time.sleep(0.1)
        time.sleep(0.5)  # a few /joint_states reach the controller

    def call(self, req: ExecutePrimitiveRequest):
        c = Call(self.proxy, req)
        c.start()
        c.join(CALL_TIMEOUT_S)
        self.assertFalse(c.is_alive(), f"call did not return within {CALL_TIMEOUT_S} s")
        self.assertIsNone(c.error)
        return c.result, c.seconds

    def assert_nothing_published(self, before: tuple[int, int]) -> None:
        time.sleep(0.5)
        self.assertEqual(self.fake.received(), before, "something was commanded for a refused request")

    def test_1_grasp_succeeds_within_the_velocity_limit(self) -> None:
        self.fake.object_width = 0.04
        n_traj, n_grip = self.fake.received()
        res, _ = self.call(request(ExecutePrimitiveRequest.GRASP, 0.05, -0.1, 0.03, yaw=0.4))
        self.assertTrue(res.success, res.message)
        self.assertTrue(res.grasped, res.message)
        self.assertEqual(res.arm, "right")
        self.assertEqual(res.message, "grasped")
        with self.fake.lock:
            trajectories = self.fake.trajectories[n_traj:]
            grips = self.fake.gripper_commands[n_grip:]
        # transit, approach, lift, home; gripper: open, close, open at home (releases the object)
        self.assertEqual(len(trajectories), 4)
        self.assertEqual([round(v, 4) for _, v in grips], [0.085, 0.0, 0.085])
        for arm, msg in trajectories:
            self.assertEqual(arm, "right")
            self.assertEqual(msg.joint_names, [f"right_{j}" for j in ARM_JOINTS])
            times = np.array([p.time_from_start.to_sec() for p in msg.points])
            q = np.array([p.positions for p in msg.points])
            v = np.array([p.velocities for p in msg.points])
            self.assertTrue(np.all(np.diff(times) > 0))
            secant = np.abs(np.diff(q, axis=0)) / np.diff(times)[:, None]
            self.assertLessEqual(secant.max(), VMAX * (1 + 1e-6))
            self.assertLessEqual(np.abs(v).max(), VMAX * (1 + 1e-6))
        # back home with the gripper open
        with self.fake.lock:
            np.testing.assert_allclose(self.fake.q["right"], GEOMETRY.robot.arms["right"].home, atol=0.02)

    def test_2_empty_grasp_and_push(self) -> None:
        self.fake.object_width = None
        n_traj, n_grip = self.fake.received()
        res, _ = self.call(request(ExecutePrimitiveRequest.GRASP, -0.1, 0.1, 0.02, yaw=1.0))
        self.assertTrue(res.success, res.message)
        self.assertFalse(res.grasped)
        self.assertEqual(res.arm, "left")
        self.assertIn("nothing grasped", res.message)
        # the last open is already reached when published, so the reply can overtake its delivery: wait up to 2 s
        deadline = time.monotonic() + 2.0
        while time.monotonic() < deadline:
            with self.fake.lock:
                n_moves = len(self.fake.trajectories) - n_traj
                grips = [round(v, 4) for _, v in self.fake.gripper_commands[n_grip:]]
            if len(grips) >= 4:
                break
            time.sleep(0.02)
        # gripper: open, close, open at the lift pose (drops what the jaw snagged there), open again at home
        self.assertEqual((n_moves, grips), (4, [0.085, 0.0, 0.085, 0.085]))
        res, _ = self.call(request(ExecutePrimitiveRequest.PUSH, 0.0, 0.1, 0.02, yaw=math.pi / 2, arm="right"))
        self.assertTrue(res.success, res.message)
        self.assertEqual((res.arm, res.message), ("right", "pushed"))

    def test_3_point_in_another_frame(self) -> None:
        # (0.25, 0.1) in table_corner = (0.05, -0.1) in world
        res, _ = self.call(request(ExecutePrimitiveRequest.PUSH, 0.25, 0.1, 0.02, frame="table_corner"))
        self.assertTrue(res.success, res.message)
        self.assertEqual(res.arm, "right")

    def test_4_refusals_publish_nothing(self) -> None:
        before = self.fake.received()
        res, _ = self.call(request(ExecutePrimitiveRequest.GRASP, 0.5, 0.0, 0.03))
        self.assertFalse(res.success)
        self.assertIn("outside the workspace", res.message)
        self.assertEqual(res.arm, "")
        res, _ = self.call(request(ExecutePrimitiveRequest.PUSH, 0.0, 0.0, 0.02, frame="nowhere"))
        self.assertFalse(res.success)
        self.assertIn("no transform from 'nowhere'", res.message)
        res, _ = self.call(request(ExecutePrimitiveRequest.GRASP, 0.0, 0.0, 0.03, arm="middle"))
        self.assertFalse(res.success)
        self.assertIn("unknown arm 'middle'", res.message)
        res, _ = self.call(request(7, 0.0, 0.0, 0.03))
        self.assertFalse(res.success)
        self.assertIn("unknown primitive", res.message)
        res, _ = self.call(request(ExecutePrimitiveRequest.GRASP, 0.0, 0.0, 0.03, frame=""))
        self.assertFalse(res.success)
        self.assertIn("frame_id is empty", res.message)
        self.assertEqual(res.arm, "")
        self.assert_nothing_published(before)

    def test_5_second_call_while_busy(self) -> None:
        n_traj, _ = self.fake.received()
        first = Call(self.proxy, request(ExecutePrimitiveRequest.GRASP, 0.0, 0.1, 0.03))
        first.start()
        deadline = time.monotonic() + 10.0
        while self.fake.received()[0] == n_traj and time.monotonic() < deadline:
            time.sleep(0.02)
        res, seconds = self.call(request(ExecutePrimitiveRequest.GRASP, 0.0, -0.1, 0.03))
        self.assertFalse(res.success)
        self.assertEqual(res.message, "busy")
        self.assertLess(seconds, 2.0)
        first.join(CALL_TIMEOUT_S)
        self.assertIsNotNone(first.result, first.error)
        self.assertTrue(first.result.success, first.result.message)

    def test_6_silent_joint_states(self) -> None:
        self.fake.paused = True
        try:
            time.sleep(2.5)
            before = self.fake.received()
            res, seconds = self.call(request(ExecutePrimitiveRequest.GRASP, 0.0, 0.0, 0.03))
            self.assertFalse(res.success)
            self.assertIn("/joint_states", res.message)
            self.assertLess(seconds, 1.0)
            self.assert_nothing_published(before)
        finally:
            self.fake.paused = False
        time.sleep(0.5)
        res, _ = self.call(request(ExecutePrimitiveRequest.GRASP, 0.0, 0.0, 0.03))
        self.assertTrue(res.success, res.message)

    def test_7_joint_states_die_mid_motion(self) -> None:
        n_traj, _ = self.fake.received()
        call = Call(self.proxy, request(ExecutePrimitiveRequest.PUSH, 0.1, 0.1, 0.02))
        call.start()
        deadline = time.monotonic() + 10.0
        while self.fake.received()[0] == n_traj and time.monotonic() < deadline:
            time.sleep(0.02)
        self.fake.paused = True
        try:
            call.join(CALL_TIMEOUT_S)
            self.assertFalse(call.is_alive())
            self.assertIsNotNone(call.result, call.error)
            self.assertFalse(call.result.success)
            self.assertIn("/joint_states", call.result.message)
            self.assertLess(call.seconds, 6.0)
        finally:
            self.fake.paused = False
        time.sleep(0.5)
        res, _ = self.call(request(ExecutePrimitiveRequest.PUSH, 0.1, 0.1, 0.02))  # plans from where the arm stopped
        self.assertTrue(res.success, res.message)

    def test_8_bad_numbers_are_refused(self) -> None:
        before = self.fake.received()
        for timeout, shown in ((math.inf, "inf"), (1e308, "1e+308"), (math.nan, "nan"), (-1.0, "-1"),
                               (-math.inf, "-inf"), (600.5, "600.5")):
            res, _ = self.call(request(ExecutePrimitiveRequest.GRASP, 0.0, 0.0, 0.03, timeout=timeout))
            self.assertFalse(res.success, res.message)
            self.assertEqual(res.arm, "", res.message)
            self.assertIn(f"timeout = {shown} s is refused", res.message)
            self.assertIn("(0, 600] s", res.message)
            self.assertIn("nothing moved", res.message)
        for field, value in (("x", math.nan), ("y", math.inf), ("z", -math.inf), ("yaw", math.nan)):
            req = request(ExecutePrimitiveRequest.PUSH, 0.0, 0.1, 0.02)
            if field == "yaw":
                req.yaw = value
            else:
                setattr(req.position.point, field, value)
            res, _ = self.call(req)
            self.assertFalse(res.success, res.message)
            self.assertEqual(res.arm, "", res.message)
            name = "yaw" if field == "yaw" else f"position.point.{field}"
            self.assertIn(f"{name} = {value} is not a finite number", res.message)
            self.assertIn("nothing moved", res.message)
        # a timeout too short for the plan: the numbers stay readable
        res, _ = self.call(request(ExecutePrimitiveRequest.PUSH, 0.0, 0.1, 0.02, timeout=1e-6))
        self.assertFalse(res.success, res.message)
        self.assertEqual(res.arm, "", res.message)
        self.assertRegex(res.message, r"^the planned motion takes [0-9.]+ s, more than the timeout of 1e-06 s; "
                                      r"nothing moved$")
        self.assert_nothing_published(before)
        res, _ = self.call(request(ExecutePrimitiveRequest.PUSH, 0.0, 0.1, 0.02, timeout=600.0))  # the maximum
        self.assertTrue(res.success, res.message)

    def test_9_overrun_names_the_limit(self) -> None:
        req = request(ExecutePrimitiveRequest.PUSH, 0.0, 0.1, 0.02, arm="right", timeout=1e-6)
        res, _ = self.call(req)
        match = re.search(r"the planned motion takes ([0-9.]+) s", res.message)
        self.assertIsNotNone(match, res.message)
        planned = float(match.group(1))
        try:
            # a stuck arm and a generous timeout: the transit ends at its planned duration plus goal_time_tolerance
            self.fake.set_slowdown(math.inf)
            req.timeout = 60.0
            res, _ = self.call(req)
            self.assertFalse(res.success, res.message)
            self.assertEqual(res.arm, "right", res.message)
            self.assertRegex(res.message, r"^'transit' failed: arm motion 'transit' did not finish within its planned "
                                          r"duration of [0-9.]+ s plus goal_time_tolerance of 1\.00 s \(final joint "
                                          r"error [0-9.]+ rad, goal_tolerance 0\.0100 rad\)$")  # the stuck arm is home
            self.assertNotIn("primitive's timeout", res.message)
            # a slow arm (each move overruns by less than goal_time_tolerance) and a timeout just above the planned
            # motion: a later move ends at the primitive's timeout; the return home has its own budget
            self.fake.set_slowdown(1.3)
            req.timeout = planned + 0.05
            res, _ = self.call(req)
            self.assertFalse(res.success, res.message)
            self.assertEqual(res.arm, "right", res.message)
            self.assertRegex(res.message, r"^'\w+' failed: arm motion '\w+' did not finish within the primitive's "
                                          rf"timeout of {req.timeout:.2f} s \(planned [0-9.]+ s, final joint error")
            self.assertNotIn("return home failed", res.message)
        finally:
            self.fake.set_slowdown(1.0)
        res, _ = self.call(request(ExecutePrimitiveRequest.PUSH, 0.0, 0.1, 0.02))
        self.assertTrue(res.success, res.message)

    def test_10_passed_deadline_is_refused(self) -> None:
        before = self.fake.received()
        req = request(ExecutePrimitiveRequest.PUSH, 0.0, 0.1, 0.02, arm="right")
        req.deadline = time.time() - 3.0
        res, _ = self.call(req)
        self.assertFalse(res.success)
        self.assertEqual(res.arm, "")
        self.assertRegex(res.message, r"^abandoned by the caller: deadline passed [0-9.]+ s ago; nothing moved$")
        req.deadline = math.nan
        res, _ = self.call(req)
        self.assertIn("deadline = nan s is refused", res.message)
        self.assert_nothing_published(before)
        # a controller stopped (SIGSTOP) until after the caller's deadline refuses the request once it runs again
        uri = rosgraph.Master("/rt_primitive_controller").lookupNode("/primitive_controller")
        pid = int(xmlrpc.client.ServerProxy(uri).getPid("/rt_primitive_controller")[2])
        os.kill(pid, signal.SIGSTOP)
        try:
            req.deadline = time.time() + 1.0
            late = Call(self.proxy, req)
            late.start()
            time.sleep(2.0)
        finally:
            os.kill(pid, signal.SIGCONT)
        late.join(CALL_TIMEOUT_S)
        self.assertFalse(late.is_alive())
        self.assertIsNone(late.error)
        self.assertFalse(late.result.success)
        self.assertIn("abandoned by the caller: deadline passed", late.result.message)
        self.assert_nothing_published(before)
        req.deadline = time.time() + CALL_TIMEOUT_S  # a deadline still ahead: the primitive runs
        res, _ = self.call(req)
        self.assertTrue(res.success, res.message)


if __name__ == "__main__":
    rostest.rosrun(PKG, "rt_primitive_controller", TestPrimitiveController)
