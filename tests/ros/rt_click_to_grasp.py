#!/usr/bin/env python3
"""Click to grasp against the simulated stack: bad target requests are refused naming the field with nothing moved;
a PointStamped on /clicked_point at an object's position (from /pg_sim/scene_state) starts a call whose decisions
(/pg/decisions) name that point and whose first grasp lands on that object; a second click meanwhile is refused
"busy" (/rosout)."""

from __future__ import annotations

import math
import threading
import time
import unittest

import rospy
import rostest
from geometry_msgs.msg import PointStamped
from pg_msgs.msg import Decision
from pg_msgs.srv import GraspTarget, ResetScene
from pg_rostest import STACK_TIMEOUT_S, fresh_scene_state, wait_service
from rosgraph_msgs.msg import Log
from sensor_msgs.msg import Image

GRASP_WAIT_S = 300.0  # wall seconds for the clicked call to reach its first grasp
NEAR_M = 0.05  # a grasp this close (x, y) to a position the object held during the call lands on it
LIFT_M = 0.03  # ... as does a grasp after which the object rose this much above its height at the click


def point(frame: str, x: float, y: float, z: float) -> PointStamped:
    msg = PointStamped()
    msg.header.frame_id, msg.header.stamp = frame, rospy.Time.now()
    msg.point.x, msg.point.y, msg.point.z = x, y, z
    return msg


class ClickToGrasp(unittest.TestCase):
    @classmethod
    def setUpClass(cls) -> None:
        rospy.init_node("rt_click_to_grasp")
        for name in ("/pg/grasp_target", "/pg/execute_primitive", "/pg_sim/reset_scene"):
            wait_service(name, STACK_TIMEOUT_S)
        cls.grasp = rospy.ServiceProxy("/pg/grasp_target", GraspTarget)
        cls.reset = rospy.ServiceProxy("/pg_sim/reset_scene", ResetScene)

    def assert_refused(self, field: str, **request) -> None:
        res = self.grasp(**request)
        self.assertFalse(res.success, request)
        self.assertIn("nothing moved", res.message, request)
        self.assertIn(f"{field}: ", res.message, request)
        self.assertEqual((res.grasps, res.pushes, len(res.decisions)), (0, 0, 0), request)

    def test_1_bad_targets_name_the_field(self) -> None:
        self.assert_refused("target and point", target="red", point=point("world", 0.0, 0.0, 0.02))
        self.assert_refused("point", point=point("world", 0.5, 0.0, 0.02))
        self.assert_refused("point", point=point("no_such_frame", 0.0, 0.0, 0.0))
        self.assert_refused("mask", mask=Image(encoding="rgb8", width=2, height=1, step=6, data=bytes(6)))

    def test_2_click_grasps_the_object(self) -> None:
        reset = self.reset(scene="packed/case01")
        self.assertTrue(reset.success, reset.message)
        state = fresh_scene_state(rospy.get_time())
        inside = [o for o in state.objects if o.in_workspace]
        # the topmost object that is not the scene's colour target (a point names any object)
        chosen = max([o for o in inside if not o.target] or inside, key=lambda o: o.pose.position.z)
        track, decisions, busy = [], [], []
        lock = threading.Lock()

        def on_state(msg) -> None:
            with lock:
                track.extend((o.pose.position.x, o.pose.position.y, o.pose.position.z) for o in msg.objects
                             if o.name == chosen.name)

        def on_log(msg: Log) -> None:
            if msg.name.endswith("pg_policy") and "refused" in msg.msg and "busy" in msg.msg:
                busy.append(msg.msg)

        subs = [rospy.Subscriber("/pg_sim/scene_state", type(state), on_state, queue_size=10),
                rospy.Subscriber("/pg/decisions", Decision, decisions.append, queue_size=100),
                rospy.Subscriber("/rosout", Log, on_log, queue_size=100)]
        pub = rospy.Publisher("/clicked_point", PointStamped, queue_size=1)
        deadline = time.monotonic() + 30.0
        while pub.get_num_connections() == 0 and time.monotonic() < deadline:
            time.sleep(0.1)
        self.assertGreater(pub.get_num_connections(), 0, "the policy node does not subscribe to /clicked_point")
        p = chosen.pose.position
        rospy.loginfo("clicking %s (%s) at (%.3f, %.3f, %.3f)", chosen.name, chosen.color_name, p.x, p.y, p.z)
        pub.publish(point("world", p.x, p.y, p.z))
        time.sleep(1.0)
        pub.publish(point("world", p.x, p.y, p.z))  # the first click's call runs (its first primitive): "busy"
        deadline = time.monotonic() + GRASP_WAIT_S
        while time.monotonic() < deadline and not any(d.primitive == Decision.GRASP for d in decisions):
            time.sleep(0.5)
        time.sleep(3.0)  # /rosout's copy of the busy refusal; the object's lift on /pg_sim/scene_state
        for sub in subs:
            sub.unregister()
        self.assertTrue(decisions, "no decision after the click")
        self.assertTrue(all(d.target.startswith("point (") for d in decisions), [d.target for d in decisions])
        grasps = [d for d in decisions if d.primitive == Decision.GRASP]
        self.assertTrue(grasps, f"no grasp within {GRASP_WAIT_S:.0f} s: {[d.message for d in decisions]}")
        g = grasps[0].position
        with lock:
            near = min(math.hypot(g.x - x, g.y - y) for x, y, _ in track) if track else math.inf
            rise = max(z for _, _, z in track) - p.z if track else 0.0
        self.assertTrue(near < NEAR_M or rise > LIFT_M,
                        f"grasp at ({g.x:.3f}, {g.y:.3f}) is {near:.3f} m from {chosen.name}, which rose {rise:.3f} m")
        self.assertTrue(busy, "a click during the call was not refused busy")


if __name__ == "__main__":
    rostest.rosrun("pg_tests", "click_to_grasp", ClickToGrasp)
