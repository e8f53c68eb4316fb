"""pg_policy.ros.bag_replay and the message conversions on a bag written here (no ROS master; needs pg_msgs built)."""

from __future__ import annotations

import math

import numpy as np
import pytest

pg_msgs = pytest.importorskip("pg_msgs.msg", reason="ROS tier: pg_msgs not built or not sourced (make setup; "
                                                      "source scripts/ros_env.sh)")
rosbag = pytest.importorskip("rosbag", reason="ROS tier: rosbag not importable (make setup installs ROS)")

from pg_conversions import heightmap_msg  # noqa: E402
from pg_core.heightmap import Heightmap  # noqa: E402
from pg_core.palette import palette_rgb  # noqa: E402
from pg_policy.decision.decision import Decision  # noqa: E402
from pg_policy.policies.registry import make_policy  # noqa: E402
from pg_policy.ros import convert  # noqa: E402
from pg_policy.ros.bag_replay import BagError, replay  # noqa: E402
from pg_policy.target_loop.loop_types import ActionRecord, Execution, PolicyObservation  # noqa: E402


def scene_heightmap(shift: int) -> Heightmap:
    color = np.full((224, 224, 3), (199, 178, 148), np.uint8)
    height = np.zeros((224, 224), np.float32)
    for r0, c0, name in ((90 + shift, 90, "green"), (90 + shift, 114, "blue"), (120, 90 + shift, "red")):
        color[r0:r0 + 22, c0:c0 + 22] = palette_rgb(name)
        height[r0:r0 + 22, c0:c0 + 22] = 0.045
    return Heightmap(color, height, np.ones((224, 224), bool), 0.002,
                     np.array([[-0.224, 0.224], [-0.224, 0.224], [0.0, 0.4]]))


def write_bag(path, tamper: bool = False) -> None:
    import rospy
    from std_msgs.msg import Header

    policy = make_policy("heuristic")
    policy.reset(1)
    with rosbag.Bag(str(path), "w") as bag:
        for i, (shift, grasped) in enumerate(((0, False), (3, True))):
            stamp = rospy.Time.from_sec(10.0 + 5 * i)
            hm = scene_heightmap(shift)
            bag.write("/pg/heightmap", heightmap_msg.heightmap_to_msg(hm, Header(frame_id="world", stamp=stamp)), stamp)
            d = policy.act(PolicyObservation(hm, "green"))
            if tamper and i == 1:
                d = Decision(d.primitive, (d.rotation + 1) % 16, d.row, d.col, d.q, d.yaw, d.x, d.y, d.z, d.grasp_q)
            ex = Execution(True, grasped, "left", "ok", 3.0, stamp.to_sec() + 3.0)
            rec = ActionRecord(1, i, "green", "heuristic", d, stamp.to_sec(), stamp.to_sec(), 400, math.nan, ex,
                               grasped and d.primitive == "grasp")
            bag.write("/pg/decisions", convert.decision_msg(rec, stamp), stamp + rospy.Duration(3.0))


def test_heightmap_message_round_trip():
    import rospy
    from std_msgs.msg import Header

    hm = scene_heightmap(0)
    back = heightmap_msg.heightmap_from_msg(heightmap_msg.heightmap_to_msg(hm, Header(stamp=rospy.Time(3))))
    assert np.array_equal(back.color, hm.color) and np.array_equal(back.height, hm.height)
    assert np.array_equal(back.valid, hm.valid) and np.allclose(back.bounds, hm.bounds) and back.resolution == 0.002


def test_heightmap_message_with_wrong_encoding_is_refused():
    import rospy
    from std_msgs.msg import Header

    msg = heightmap_msg.heightmap_to_msg(scene_heightmap(0), Header(stamp=rospy.Time(3)))
    msg.height.encoding = "16UC1"
    with pytest.raises(ValueError, match="encoding"):
        heightmap_msg.heightmap_from_msg(msg)


def test_replay_reproduces_metrics_and_decisions(tmp_path):
    bag = tmp_path / "run.bag"
    write_bag(bag)
    rep = replay(bag, make_policy)
    assert rep.decisions == 2 and list(rep.episodes) == [1]
    ep = rep.episodes[1]
    assert ep.pushes + ep.grasps == 2
    assert rep.compared == 2 and rep.agreement == 1.0 and rep.missing_heightmaps == 0
    assert rep.metrics["C"].mean == float(ep.completed)


def test_replay_reports_disagreement(tmp_path):
    bag = tmp_path / "run.bag"
    write_bag(bag, tamper=True)
    rep = replay(bag, make_policy)
    assert rep.compared == 2 and rep.agreed == 1 and "action 1" in rep.disagreements[0]


def test_corrupt_or_empty_bag_is_a_clear_error(tmp_path):
    bad = tmp_path / "bad.bag"
    bad.write_bytes(b"not a bag at all")
    with pytest.raises(BagError, match="cannot read"):
        replay(bad)
    empty = tmp_path / "empty.bag"
    with rosbag.Bag(str(empty), "w"):
        pass
    with pytest.raises(BagError, match="no /pg/decisions"):
        replay(empty)
    with pytest.raises(BagError, match="not found"):
        replay(tmp_path / "missing.bag")
