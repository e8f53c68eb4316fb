#!/usr/bin/env python3
"""record.launch during a live grasp_target call, then `pushgrasp replay` on the bag: same metrics as the live
answer, 100 % decision agreement."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import time
import unittest
from pathlib import Path

import rospy
import rostest
from pg_msgs.srv import GraspTarget
from pg_rostest import STACK_TIMEOUT_S, wait_service


class RecordReplay(unittest.TestCase):
    def test_replay_matches_live_call(self) -> None:
        rospy.init_node("rt_record_replay")
        bag = Path(rospy.get_param("~bag"))
        wait_service("/pg/grasp_target", STACK_TIMEOUT_S)
        time.sleep(3.0)  # rosbag record subscribes to topics as it discovers them
        live = rospy.ServiceProxy("/pg/grasp_target", GraspTarget)(target="green", timeout=400.0)
        rospy.loginfo("live: %s %s grasps %d pushes %d", live.success, live.message, live.grasps, live.pushes)
        self.assertGreater(len(live.decisions), 0, live.message)
        time.sleep(2.0)
        subprocess.run(["rosnode", "kill", "/pg_record"], check=True, capture_output=True, timeout=30)
        deadline = time.monotonic() + 30.0
        while not bag.exists() and time.monotonic() < deadline:
            time.sleep(0.5)
        self.assertTrue(bag.exists(), f"{bag} was not closed by rosbag record")
        out = bag.with_suffix(".json")
        proc = subprocess.run([sys.executable, "-m", "pg_policy.cli.main", "replay", str(bag), "--json", str(out)],
                              capture_output=True, text=True, timeout=300, env=dict(os.environ))
        self.assertEqual(proc.returncode, 0, proc.stdout + proc.stderr)
        rospy.loginfo("pushgrasp replay:\n%s", proc.stdout)
        report = json.loads(out.read_text())
        episodes = list(report["episodes"].values())
        self.assertEqual(len(episodes), 1)
        ep = episodes[0]
        self.assertEqual(ep["completed"], live.success)
        self.assertEqual(ep["grasps"], live.grasps)
        self.assertEqual(ep["pushes"], live.pushes)
        self.assertEqual(report["decisions"], len(live.decisions))
        self.assertEqual(report["metrics"]["C"]["mean"], 1.0 if live.success else 0.0)
        self.assertEqual(report["missing_heightmaps"], 0)
        self.assertEqual(report["agreement"], 1.0, report["disagreements"])


if __name__ == "__main__":
    rostest.rosrun("pg_tests", "record_replay", RecordReplay)
