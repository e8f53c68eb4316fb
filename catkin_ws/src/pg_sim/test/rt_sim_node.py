#!/usr/bin/env python3
"""rostest node of sim_node.test: the sim node looks like the real robot and camera on ROS (DESIGN.md section 5).

Every wait is bounded (wall-clock timeouts), so a dead sim fails the test instead of hanging it.
"""

from __future__ import annotations

import os
import shutil
import tempfile
import time
import unittest

import numpy as np
import rospy
import rostest
import tf2_ros
from pg_msgs.msg import SceneState
from pg_msgs.srv import ResetScene
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import JointState, PointCloud2
from std_msgs.msg import UInt32
from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint

ARM_JOINTS = ("shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint", "wrist_1_joint", "wrist_2_joint",
              "wrist_3_joint")
WAIT = 60.0  # s wall: the sim node may still be starting (scene load, first render)
SCENE_FOLDER = "/tmp/pg_sim_rostest"  # the ~scene_folders entry of sim_node.test


def wait_for(predicate, timeout: float, what: str):
    """Poll until predicate() gives an array (a value ready) or something truthy; AssertionError on timeout."""
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        value = predicate()
        if value is not None and (isinstance(value, np.ndarray) or bool(value)):
            return value
        time.sleep(0.02)
    raise AssertionError(f"timed out after {timeout:.0f} s waiting for {what}")


class SimNodeTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls) -> None:
        rospy.init_node("rt_sim_node")
        cls.joint_state: JointState | None = None
        cls.scene_states: list[SceneState] = []
        cls.js_sub = rospy.Subscriber("/joint_states", JointState, cls._on_js, queue_size=5)
        cls.scene_sub = rospy.Subscriber("/pg_sim/scene_state", SceneState, cls._on_scene, queue_size=20)
        cls.resets: list[int] = []
        cls.resets_sub = rospy.Subscriber("/pg_sim/scene_resets", UInt32, lambda m: cls.resets.append(m.data))
        cls.tf_buffer = tf2_ros.Buffer()
        cls.tf_listener = tf2_ros.TransformListener(cls.tf_buffer)

    @classmethod
    def _on_js(cls, msg: JointState) -> None:
        cls.joint_state = msg

    @classmethod
    def _on_scene(cls, msg: SceneState) -> None:
        cls.scene_states.append(msg)

    def left_joints(self) -> np.ndarray | None:
        js = self.joint_state
        if js is None:
            return None
        pos = dict(zip(js.name, js.position, strict=True))
        return np.array([pos[f"left_{n}"] for n in ARM_JOINTS])

    def reset(self, scene: str, num_objects: int = 0, seed: int = 0):
        rospy.wait_for_service("/pg_sim/reset_scene", timeout=WAIT)
        return rospy.ServiceProxy("/pg_sim/reset_scene", ResetScene)(scene=scene, num_objects=num_objects, seed=seed)

    def send_left(self, goal: np.ndarray, seconds: float) -> None:
        pub = rospy.Publisher("/left/scaled_pos_joint_traj_controller/command", JointTrajectory, queue_size=1)
        wait_for(lambda: pub.get_num_connections() > 0, WAIT, "the sim node to subscribe to the trajectory topic")
        msg = JointTrajectory(joint_names=[f"left_{n}" for n in ARM_JOINTS])
        msg.points = [JointTrajectoryPoint(positions=goal.tolist(), velocities=[0.0] * 6,
                                           time_from_start=rospy.Duration(seconds))]
        pub.publish(msg)

    def test_1_clock_advances(self) -> None:
        first = rospy.wait_for_message("/clock", Clock, timeout=WAIT).clock
        time.sleep(0.5)
        second = rospy.wait_for_message("/clock", Clock, timeout=WAIT).clock
        self.assertGreater(second, first)
        wait_for(lambda: rospy.Time.now() > first, 10.0, "rospy sim time to follow /clock")

    def test_2_joint_states(self) -> None:
        wait_for(lambda: self.joint_state is not None, WAIT, "/joint_states")
        js = self.joint_state
        self.assertEqual(len(js.name), 16)
        self.assertEqual(len(js.position), 16)
        self.assertEqual(len(js.velocity), 16)
        for arm in ("left", "right"):
            for n in (*ARM_JOINTS, "gripper_finger1_joint", "gripper_finger2_joint"):
                self.assertIn(f"{arm}_{n}", js.name)
        self.assertGreater(js.header.stamp.to_sec(), 0.0)

    def test_3_camera_cloud(self) -> None:
        cloud = rospy.wait_for_message("/camera/depth/color/points", PointCloud2, timeout=WAIT)
        self.assertEqual((cloud.height, cloud.width), (480, 640))
        self.assertEqual(cloud.header.frame_id, "camera_color_optical_frame")
        self.assertEqual([f.name for f in cloud.fields], ["x", "y", "z", "rgb"])
        self.assertEqual(len(cloud.data), cloud.row_step * cloud.height)
        pts = np.frombuffer(cloud.data, dtype=np.float32).reshape(480, 640, cloud.point_step // 4)
        z = pts[..., 2]
        self.assertGreater(np.isfinite(z).mean(), 0.9)  # the table fills most of the view
        self.assertTrue(0.5 < float(np.nanmedian(z)) < 0.75)  # ~0.7 m down to the table

    def test_4_tf(self) -> None:
        timeout = rospy.Duration(WAIT)
        cam = self.tf_buffer.lookup_transform("world", "camera_color_optical_frame", rospy.Time(0), timeout)
        t = cam.transform.translation
        np.testing.assert_allclose([t.x, t.y, t.z], [0.0, 0.0, 0.70], atol=1e-6)
        tool = self.tf_buffer.lookup_transform("world", "left_tool0", rospy.Time(0), timeout)
        self.assertGreater(tool.transform.translation.y, 0.0)  # the left arm works from +y

    def test_5_trajectory_moves_left_arm(self) -> None:
        start = wait_for(self.left_joints, WAIT, "/joint_states")
        goal = start + np.array([0.3, 0.15, -0.2, 0.1, 0.2, 0.4])
        t0 = rospy.Time.now()
        self.send_left(goal, 1.5)
        wait_for(lambda: np.abs(self.left_joints() - goal).max() < 5e-3, WAIT, "the left arm to reach the goal")
        took = (self.joint_state.header.stamp - t0).to_sec()
        rospy.loginfo(f"rt_sim_node: trajectory of 1.5 s reached its goal after {took:.3f} s of sim time")
        self.assertGreater(took, 1.2)  # it followed the timing, it did not jump
        wait_for(lambda: rospy.Time.now() > t0 + rospy.Duration(1.8), WAIT, "the trajectory's end (resets wait for it)")
        tool = self.tf_buffer.lookup_transform("world", "left_tool0", rospy.Time(0), rospy.Duration(10.0))
        self.assertIsNotNone(tool)

    def test_6_reset_scene(self) -> None:
        res = self.reset("household/case11")
        self.assertTrue(res.success, res.message)
        self.assertEqual((res.scene_name, res.target, res.num_objects), ("household/case11", "green", 5))
        state = wait_for(lambda: next((s for s in reversed(self.scene_states) if s.scene == "household/case11"),
                                      None), WAIT, "scene_state of household/case11")
        self.assertEqual(len(state.objects), 5)
        self.assertEqual([o.name for o in state.objects if o.target], ["milk_box_0"])
        self.assertTrue(state.target_in_workspace)
        self.assertEqual(state.header.frame_id, "world")

    def test_7_unknown_scene_changes_nothing(self) -> None:
        self.reset("household/case11")
        n_states = len(self.scene_states)
        before = {o.name: o.pose.position for o in self.scene_states[-1].objects}
        res = self.reset("household/no_such_case")
        self.assertFalse(res.success)
        self.assertIn("not found", res.message)
        self.assertIn("household/no_such_case", res.message)
        wait_for(lambda: len(self.scene_states) > n_states, WAIT, "a scene_state after the refused reset")
        after = self.scene_states[-1]
        self.assertEqual(after.scene, "household/case11")
        self.assertEqual(set(before), {o.name for o in after.objects})
        for o in after.objects:
            p = before[o.name]
            self.assertLess(abs(o.pose.position.x - p.x) + abs(o.pose.position.y - p.y), 1e-3)

    def test_8_resets_are_counted_and_refusals_name_the_field(self) -> None:
        wait_for(lambda: self.resets, WAIT, "the latched /pg_sim/scene_resets")
        count = self.resets[-1]
        res = self.reset("packed/case02")
        self.assertTrue(res.success, res.message)
        wait_for(lambda: self.resets[-1] == count + 1, 10.0, "the count after a successful reset")
        refusals = [(("random", 10, -5), "seed: must be a non-negative integer, got -5"),
                    (("random", 25, 1), "num_objects: a random scene needs num_objects in [1, 20], got 25"),
                    (("../../../../../../../../etc/passwd", 0, 0), "scene '../../../../../../../../etc/passwd' "
                                                                   "(resolved: '/etc/passwd') is outside the allowed")]
        for (scene, n, seed), match in refusals:
            res = self.reset(scene, n, seed)
            self.assertFalse(res.success)
            self.assertEqual(res.message[:len("reset refused, scene unchanged: ")], "reset refused, scene unchanged: ")
            self.assertIn(match, res.message)
        os.makedirs(SCENE_FOLDER, exist_ok=True)
        folder = tempfile.mkdtemp(dir=SCENE_FOLDER)
        path = os.path.join(folder, "one.yaml")
        with open(path, "w", encoding="utf-8") as f:
            f.write("name: one\nobjects:\n  - {shape: cube, color: green, pose: [0, 0, 2.25e-2, 0, 0, 0]}\n")
        res = self.reset(path)
        shutil.rmtree(folder, ignore_errors=True)
        self.assertTrue(res.success, res.message)
        self.assertEqual((res.scene_name, res.num_objects), ("one", 1))
        wait_for(lambda: self.resets[-1] == count + 2, 10.0, "the count after a second successful reset")
        self.assertEqual(self.resets[-1], count + 2)  # refusals did not count

    def test_9_reset_is_refused_while_an_arm_executes_a_trajectory(self) -> None:
        self.assertTrue(self.reset("household/case11").success)
        start = wait_for(self.left_joints, WAIT, "/joint_states")
        goal = start + np.array([0.3, 0.15, -0.2, 0.1, 0.2, 0.4])
        self.send_left(goal, 3.0)
        wait_for(lambda: np.abs(self.left_joints() - start).max() > 0.02, WAIT, "the left arm to start moving")
        # the trajectory's clock starts when the arm moves (the reset just before it stepped the world on for its
        # stillness watch, so this client's ROS time may lag the sim's when the goal is sent)
        t0 = rospy.Time.now()
        counts = list(self.resets)
        res = self.reset("packed/case03")
        self.assertFalse(res.success)
        self.assertTrue(res.message.startswith("busy: arm left is executing a trajectory"), res.message)
        wait_for(lambda: rospy.Time.now() > t0 + rospy.Duration(3.3), WAIT, "the trajectory's end")
        self.assertLess(np.abs(self.left_joints() - goal).max(), 5e-3)
        self.assertEqual(self.scene_states[-1].scene, "household/case11")
        self.assertEqual(self.resets, counts)  # a refusal is not counted
        res = self.reset("packed/case03")
        self.assertTrue(res.success, res.message)


if __name__ == "__main__":
    rostest.rosrun("pg_sim", "sim_node", SimNodeTest)
