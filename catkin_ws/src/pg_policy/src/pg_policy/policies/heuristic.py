"""The `heuristic` baseline policy: pg_policy.policies.heuristic_planner's geometric rule, with the trial's memory."""

from __future__ import annotations

from typing import Any

import numpy as np

from pg_policy.decision.decision import Decision
from pg_policy.decision.rules.failed_grasps import FailedGrasps
from pg_policy.policies.heuristic_planner import HeuristicParams, HeuristicPlanner
from pg_policy.policies.policy import PolicyBase, PolicyOptions, observed_target


class HeuristicPolicy(PolicyBase):
    """The planner's rule; remembers, within a trial, the grasps it tried (a later act() means they failed) and
    where the target was last seen. PolicyOptions.extra["heuristic_params"] overrides HeuristicParams."""

    name = "heuristic"

    def __init__(self, opts: PolicyOptions) -> None:
        super().__init__(opts)
        self.planner = HeuristicPlanner(self.geometry, opts.extra.get("heuristic_params") or HeuristicParams())
        self.failed = FailedGrasps(self.rotations)  # storage only: the planner applies its own repeat_radius
        self.last_seen: np.ndarray | None = None
        self.last_action: Any = None
        self.last_note = ""  # why the last decision was taken (logged by the evaluation)
        self.pushes_in_row = 0

    def reset(self, seed: int | None = None) -> None:
        super().reset(seed)
        self.failed.clear()
        self.last_seen, self.last_action, self.last_note = None, None, ""
        self.pushes_in_row = 0

    def act(self, obs: Any) -> Decision:
        hm = obs.heightmap
        target = observed_target(obs)
        if self.planner.visible(target):
            rows, cols = np.nonzero(target)
            self.last_seen = np.array([hm.bounds[0, 0] + (cols.mean() + 0.5) * hm.resolution,
                                       hm.bounds[1, 0] + (rows.mean() + 0.5) * hm.resolution])
        act = self.planner.plan(hm, target, self.failed.grasps, self.last_seen, self.rng, self.pushes_in_row)
        self.last_action, self.last_note = act, act.why
        self.pushes_in_row = self.pushes_in_row + 1 if act.primitive == "push" else 0
        d = self.decision(hm, act.primitive, act.rotation, act.row, act.col)
        if act.primitive == "grasp":
            self.failed.add(act.rotation, d.x, d.y)  # a later act() in this trial means it failed
        return d
