"""The `heuristic` baseline policy: pg_policy.policies.heuristic_planner's geometric rule, with the trial's memory.

Within an episode the target memory comes with the observation (`obs.search`, pg_policy.perception.target_memory):
where the target was last seen (the planner's `last_seen`), what covers that place while it is hidden (the object
covering most of it is grasped away first), and the pushes that changed nothing (never repeated: a random push
instead). Without it (a bare observation) the policy keeps its own last sighting.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from pg_core.heightmap import Heightmap, pixel_to_world
from pg_policy.decision.decision import Decision
from pg_policy.decision.jaw_fit import CellWindow, dilate
from pg_policy.decision.rules.failed_grasps import FailedGrasps
from pg_policy.policies.heuristic_planner import Action, HeuristicParams, HeuristicPlanner
from pg_policy.policies.policy import PolicyBase, PolicyOptions, observed_target

RANDOM_PUSH_TRIES = 20  # random pushes drawn to replace a futile one before giving up


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
        search = getattr(obs, "search", None)
        if search is not None:  # the episode's memory
            seen = search.last_seen
            self.last_seen = None if seen is None else np.array([seen.x, seen.y])
        elif self.planner.visible(target):
            rows, cols = np.nonzero(target)
            self.last_seen = np.array(pixel_to_world(rows.mean(), cols.mean(), hm.bounds, hm.resolution))
        act = None
        if search is not None and not self.planner.visible(target):
            act = self.search(hm, search)
        if act is None:
            act = self.planner.plan(hm, target, self.failed.grasps, self.last_seen, self.rng, self.pushes_in_row)
        act = self.not_futile(hm, act, search)
        self.last_action, self.last_note = act, act.why
        self.pushes_in_row = self.pushes_in_row + 1 if act.primitive == "push" else 0
        d = self.decision(hm, act.primitive, act.rotation, act.row, act.col)
        if act.primitive == "grasp":
            self.failed.add(act.rotation, d.x, d.y)  # a later act() in this trial means it failed
        return d

    def search(self, hm: Heightmap, search: Any) -> Action | None:
        """Target hidden: grasp away the object covering most of the place it was last seen (the memory's search
        goal, TargetSearch.goal); None when nothing covers it or no such object can be grasped."""
        goal = search.goal(hm, self.planner.p.occupied)
        if goal is None:
            return None
        occupied = hm.height > self.planner.p.occupied
        best: Action | None = None
        for name, blob, centre in self.planner.blobs(hm):
            cover = int((blob & goal).sum())
            if cover == 0 or (best is not None and cover <= best.score):
                continue
            act = self.planner.best_grasp(hm, blob, occupied & ~dilate(blob, 1),
                                          CellWindow(hm, centre, self.planner.p.window), self.failed.grasps)
            if act is not None:
                best = Action("grasp", act.rotation, act.row, act.col, cover, f"{search.note(True)}: grasp {name} "
                              "object")
        return best

    def not_futile(self, hm: Heightmap, act: Action, search: Any) -> Action:
        """`act`, or a random push when it repeats a push that changed nothing (the episode would refuse it)."""
        if search is None or act.primitive != "push":
            return act
        for _ in range(RANDOM_PUSH_TRIES):
            x, y = pixel_to_world(act.row, act.col, hm.bounds, hm.resolution)
            if not search.is_futile_repeat("push", act.rotation, x, y):
                return act
            fallback = self.planner.fallback(hm, self.rng)
            act = Action(fallback.primitive, fallback.rotation, fallback.row, fallback.col, fallback.score,
                         "futile push not repeated: random push")
        return act
