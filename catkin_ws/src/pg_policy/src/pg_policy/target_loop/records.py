"""The record of one episode of the protocol (pg_policy.target_loop.episode) and its JSON form.

A TrialRecord holds what an episode did: scene name, seed, counts, why it ended, and every action (decision +
outcome, and the target as the episode saw it: ``target``, see pg_learning.evaluation.runner) in order;
``wrong_grasps`` counts the grasps that held another object than the target, from the outcomes.
`pushgrasp eval` writes one per trial (pg_learning.evaluation: results.json, trials.jsonl), the
bag replay builds one per recorded grasp_target call (pg_policy.ros.bag_replay); the metrics over records are
pg_policy.target_loop.metrics.

JSON: ``TrialRecord.to_dict`` (the fields plus the derived ``n_actions`` and ``grasp_success``), ``record_from_dict``
back (derived entries dropped), and ``plain`` for any value that goes into a JSON file (dataclasses -> dicts, numpy
scalars and arrays -> Python numbers and lists, NaN and infinities -> None).
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field, fields, is_dataclass
from typing import Any

import numpy as np


@dataclass
class TrialRecord:
    """One trial: scene name, seed, counts, why it ended, and every action (decision + outcome) in order."""

    scene: str
    seed: int
    completed: bool = False
    termination: str = ""  # "completed", "target_lost", "target_not_found", "failed_grasps", "max_actions", "error"
    # (pg_policy.target_loop.episode)
    grasps: int = 0  # executed grasp attempts
    target_grasps: int = 0
    failed_grasps: int = 0
    pushes: int = 0  # executed pushes
    refused: int = 0
    actions: list[dict[str, Any]] = field(default_factory=list)
    wall_s: float = 0.0
    sim_s: float = 0.0
    error: str | None = None  # termination "error": "ExceptionType: message" (pg_learning.evaluation.errors)
    error_at: str | None = None  # where it was raised: scene, env.make, policy.act, env.step, worker, ...
    error_trace: str | None = None  # innermost traceback frames
    message: str = ""  # why the trial ended, in words (e.g. "target lost: seen leaving the workspace at (x, y)")

    @property
    def n_actions(self) -> int:
        return len(self.actions)

    @property
    def grasp_success(self) -> float | None:
        """target grasps / grasp attempts of this trial, None without attempts."""
        return self.target_grasps / self.grasps if self.grasps else None

    @property
    def wrong_grasps(self) -> int:
        """Executed grasps that held an object other than the target (ground truth of the simulator: the outcome's
        ``grasped_color`` names what was held and ``target_grasped`` is false); 0 for records whose outcomes do not
        say what was held. Each is also a failed grasp."""
        return sum(1 for a in self.actions if _wrong_grasp(a.get("outcome")))

    def to_dict(self) -> dict[str, Any]:
        return {**asdict(self), "n_actions": self.n_actions, "grasp_success": self.grasp_success}


def _wrong_grasp(outcome: Any) -> bool:
    """Whether one action's outcome (StepResult as a dict) is an executed grasp that held another object."""
    if not isinstance(outcome, dict) or outcome.get("primitive") != "grasp" or outcome.get("refused"):
        return False
    return outcome.get("grasped_color") is not None and not outcome.get("target_grasped")


def record_from_dict(d: dict[str, Any]) -> TrialRecord:
    """The TrialRecord of TrialRecord.to_dict's output (derived entries dropped)."""
    names = {f.name for f in fields(TrialRecord)}
    return TrialRecord(**{k: v for k, v in d.items() if k in names})


def plain(obj: Any) -> Any:
    """JSON-friendly copy: dataclasses -> dicts, numpy scalars/arrays -> Python numbers/lists, NaN -> None."""
    if is_dataclass(obj) and not isinstance(obj, type):
        return {k: plain(v) for k, v in asdict(obj).items()}
    if isinstance(obj, dict):
        return {str(k): plain(v) for k, v in obj.items()}
    if isinstance(obj, list | tuple):
        return [plain(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return plain(obj.tolist())
    if isinstance(obj, np.generic):
        obj = obj.item()
    if isinstance(obj, float) and not math.isfinite(obj):
        return None
    return obj
