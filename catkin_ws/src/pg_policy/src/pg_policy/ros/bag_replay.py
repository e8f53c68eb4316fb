"""Metrics and decision agreement from a recorded bag (record.launch): the core of `pushgrasp replay`.

Reads /pg/decisions (pg_msgs/Decision, one per executed action) and /pg/heightmap (pg_msgs/Heightmap) with the
rosbag library (no ROS master; message classes come from the bag itself). Episodes are grasp_target calls
(Decision.episode). Per episode, as in DESIGN.md section 8: completed when a grasp lifted the target; grasp
attempts and target grasps count executed grasps; pushes count executed pushes. Re-running a policy on the recorded
heightmaps (each decision's heightmap_stamp) in the recorded order, reset per episode with the episode number as
its seed like the policy node does, gives the decision agreement: same primitive, rotation, row and column.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from pg_conversions.heightmap_msg import heightmap_from_msg
from pg_policy.ros.convert import primitive_name
from pg_policy.target_loop.loop_types import PolicyObservation
from pg_policy.target_loop.metrics import Stat, scene_metrics
from pg_policy.target_loop.records import TrialRecord

DECISIONS = "/pg/decisions"
HEIGHTMAP = "/pg/heightmap"


class BagError(ValueError):
    """Unreadable bag, or one without the topics a replay needs."""


@dataclass
class Replay:
    episodes: dict[int, TrialRecord] = field(default_factory=dict)
    metrics: dict[str, Stat] = field(default_factory=dict)
    decisions: int = 0
    compared: int = 0
    agreed: int = 0
    missing_heightmaps: int = 0
    disagreements: list[str] = field(default_factory=list)

    @property
    def agreement(self) -> float | None:
        return self.agreed / self.compared if self.compared else None


def read_bag(path: str | Path) -> tuple[list[Any], dict[float, Any]]:
    """(decisions in bag order, heightmap messages by header stamp in seconds); BagError when unreadable."""
    import rosbag

    path = Path(path)
    if not path.is_file():
        raise BagError(f"bag not found: {path}")
    decisions, heightmaps = [], {}
    try:
        with rosbag.Bag(str(path)) as bag:
            for topic, msg, _ in bag.read_messages(topics=[DECISIONS, HEIGHTMAP]):
                if topic == DECISIONS:
                    decisions.append(msg)
                else:
                    heightmaps[round(msg.header.stamp.to_sec(), 6)] = msg
    except (rosbag.ROSBagException, OSError) as exc:
        raise BagError(f"cannot read bag {path}: {exc}") from None
    if not decisions:
        raise BagError(f"bag {path} holds no {DECISIONS} messages (was record.launch running during the call?)")
    return decisions, heightmaps


def episode_records(decisions: Iterable[Any]) -> dict[int, TrialRecord]:
    """Per-episode trial records from executed decisions (DESIGN.md section 8 counting)."""

    out: dict[int, TrialRecord] = {}
    for d in decisions:
        if not d.executed:
            continue
        rec = out.setdefault(int(d.episode), TrialRecord(scene=f"episode {d.episode}", seed=int(d.episode)))
        rec.actions.append({"index": int(d.action_index), "primitive": primitive_name(d), "success": d.success})
        if not d.success:
            rec.refused += 1
        elif primitive_name(d) == "grasp":
            rec.grasps += 1
            rec.target_grasps += int(d.target_grasped)
            rec.failed_grasps += int(not d.target_grasped)
        else:
            rec.pushes += 1
        rec.completed = rec.completed or bool(d.target_grasped)
        rec.termination = "completed" if rec.completed else "incomplete"
    return out


def replay(path: str | Path, make_policy: Callable[[str], Any] | None = None,
           policy: str | None = None) -> Replay:
    """Metrics of the bag and, when `make_policy` is given, agreement of `policy` (default: the recorded one)
    re-run on the recorded heightmaps."""

    decisions, heightmaps = read_bag(path)
    out = Replay(episodes=episode_records(decisions), decisions=len(decisions))
    out.metrics = scene_metrics(list(out.episodes.values()))
    if make_policy is None:
        return out
    policies: dict[str, Any] = {}
    episode = None
    for d in decisions:
        name = policy or d.policy
        if name not in policies:
            policies[name] = make_policy(name)
        pol = policies[name]
        if d.episode != episode:
            episode = d.episode
            pol.reset(int(d.episode))
        msg = heightmaps.get(round(d.heightmap_stamp.to_sec(), 6))
        if msg is None:
            out.missing_heightmaps += 1
            continue
        again = pol.act(PolicyObservation(heightmap_from_msg(msg), d.target))
        out.compared += 1
        same = (again.primitive, again.rotation, again.row, again.col) == (primitive_name(d), d.rotation, d.row, d.col)
        out.agreed += int(same)
        if not same:
            out.disagreements.append(
                f"episode {d.episode} action {d.action_index}: recorded {primitive_name(d)} r{d.rotation} "
                f"({d.row}, {d.col}), replayed {again.primitive} r{again.rotation} ({again.row}, {again.col})")
    return out
