#!/usr/bin/env python3
"""rostest node of sim_node.test: the sim node looks like the real robot and camera on ROS (DESIGN.md section 5).

Every wait is bounded (wall-clock timeouts), so a dead sim fails the test instead of hanging it.
"""

from __future__ import annotations

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
from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint

ARM_JOINTS = ("shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint", "wrist_1_joint", "wrist_2_joint",
              "wrist_3_joint")
WAIT = 60.0  # s wall: the sim node may still be starting (scene load, first render)


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

    def reset(self, scene: str):
        rospy.wait_for_service("/pg_sim/reset_scene", timeout=WAIT)
        return rospy.ServiceProxy("/pg_sim/reset_scene", ResetScene)(scene=scene, num_objects=0, seed=0)

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
        pub = rospy.Publisher("/left/scaled_pos_joint_traj_controller/command", JointTrajectory, queue_size=1)
        wait_for(lambda: pub.get_num_connections() > 0, WAIT, "the sim node to subscribe to the trajectory topic")
        msg = JointTrajectory(joint_names=[f"left_{n}" for n in ARM_JOINTS])
        msg.points = [JointTrajectoryPoint(positions=goal.tolist(), velocities=[0.0] * 6,
                                           time_from_start=rospy.Duration(1.5))]
        t0 = rospy.Time.now()
        pub.publish(msg)
        wait_for(lambda: np.abs(self.left_joints() - goal).max() < 5e-3, WAIT, "the left arm to reach the goal")
        took = (self.joint_state.header.stamp - t0).to_sec()
        rospy.loginfo(f"rt_sim_node: trajectory of 1.5 s reached its goal after {took:.3f} s of sim time")
        self.assertGreater(took, 1.2)  # it followed the timing, it did not jump
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


if __name__ == "__main__":
    rostest.rosrun("pg_sim", "sim_node", SimNodeTest)
