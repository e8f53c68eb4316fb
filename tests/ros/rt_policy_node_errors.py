#!/usr/bin/env python3
"""The policy node refuses to start, with the reason, on a missing, corrupt or unknown model/policy; it loads a
shipped TorchScript model and answers /pg/infer with it ("learned" policy) on a scripted heightmap."""

from __future__ import annotations

import os
import subprocess
import tempfile
import unittest
from pathlib import Path

import numpy as np
import rospy
import rostest
from pg_msgs.msg import Heightmap as HeightmapMsg
from pg_msgs.srv import Infer
from pg_rostest import wait_service
from std_msgs.msg import Header

from pg_core.resources import shipped_models

MODELS = shipped_models()


def start(policy: str, name: str) -> subprocess.Popen:
    return subprocess.Popen(["rosrun", "pg_policy", "policy_node", f"__name:={name}", f"_policy:={policy}"],
                            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, env=dict(os.environ))


class PolicyNodeErrors(unittest.TestCase):
    @classmethod
    def setUpClass(cls) -> None:
        rospy.init_node("rt_policy_node_errors")

    def assertRefusesToStart(self, policy: str, reason: str) -> None:
        proc = start(policy, "pg_policy_bad")
        out, _ = proc.communicate(timeout=120)
        self.assertEqual(proc.returncode, 1, out)
        self.assertIn("policy node cannot start", out)
        self.assertIn(reason, out)

    def test_missing_model_file(self) -> None:
        self.assertRefusesToStart("/no/such/model.pt", "not found")

    def test_corrupt_model_file(self) -> None:
        bad = Path(tempfile.mkdtemp()) / "grasp.pt"
        bad.write_bytes(b"this is not a TorchScript archive")
        self.assertRefusesToStart(str(bad), str(bad))

    def test_unknown_policy_name(self) -> None:
        self.assertRefusesToStart("clairvoyant", "unknown policy 'clairvoyant'")

    def test_shipped_model_loads_and_decides(self) -> None:
        model = next(p for p in sorted(MODELS.iterdir()) if (p / "grasp.pt").is_file())
        proc = start(str(model), "pg_policy")
        try:
            wait_service("/pg/infer", 120.0)
            from pg_conversions.heightmap_msg import heightmap_to_msg
            from pg_core.heightmap import Heightmap
            from pg_core.palette import palette_rgb

            color = np.full((224, 224, 3), (199, 178, 148), np.uint8)
            height = np.zeros((224, 224), np.float32)
            color[100:122, 100:122], height[100:122, 100:122] = palette_rgb("green"), 0.045
            hm = Heightmap(color, height, np.ones((224, 224), bool), 0.002,
                           np.array([[-0.224, 0.224], [-0.224, 0.224], [0.0, 0.4]]))
            pub = rospy.Publisher("/pg/heightmap", HeightmapMsg, queue_size=1, latch=True)
            infer = rospy.ServiceProxy("/pg/infer", Infer)
            call = None
            for _ in range(20):  # the node wants a heightmap newer than the call: keep publishing fresh ones
                pub.publish(heightmap_to_msg(hm, Header(frame_id="world", stamp=rospy.Time.now() + rospy.Duration(1))))
                call = infer(target="green")
                if call.success:
                    break
            self.assertTrue(call.success, call.message)
            self.assertTrue(np.isfinite(call.decision.grasp_q), "a learned policy reports its masked max Q_g")
            self.assertEqual(call.decision.policy, str(model))
        finally:
            proc.terminate()
            proc.wait(20)


if __name__ == "__main__":
    rostest.rosrun("pg_tests", "policy_node_errors", PolicyNodeErrors)
