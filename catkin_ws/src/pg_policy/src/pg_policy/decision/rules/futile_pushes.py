"""Within-trial memory of pushes that changed nothing, so a deterministic greedy policy does not repeat one.

A push that leaves the scene around the target unchanged (pg_policy.perception.scene_change.scene_changed with the
trainer's ``PUSH_CHANGE_RADIUS_M``, the rule that gives such a push R_p = -0.5 in training) leaves the heightmap, and
with it the argmax of Q_p, where it was: the learned policy then pushed at the same cell and rotation again, up to six
times in a row, typically at the workspace edge where the push end is clipped (docs/RESULTS.md). Suppressing that push
direction within `radius_m` of where it started makes the next push try something else. Unlike a grasp, a push is not
symmetric: only its own rotation index is suppressed. As a test-time rule (pg_policy.decision.rules.rule) it is
"futile_pushes[:RADIUS_M]". The episode protocol keeps a memory of its own that binds every policy
(pg_policy.perception.target_memory: a push that changed nothing anywhere along its path is refused when repeated,
and the learned policy suppresses it in Q_p); this rule adds the stricter "nothing changed around the target".
"""

from __future__ import annotations

from typing import Any

import numpy as np

from pg_core.geometry import Geometry
from pg_core.heightmap import Heightmap
from pg_policy.decision.option import PolicyOption
from pg_policy.decision.rules.failed_grasps import parse_radius, suppress_near
from pg_policy.decision.rules.rule import Rule, RuleContext
from pg_policy.perception.scene_change import PUSH_CHANGE_RADIUS_M, scene_changed
from pg_policy.perception.target_memory import FUTILE_PUSH_RADIUS_M

DEFAULT_RADIUS_M = 0.0  # off unless the rule list names it: not in the shipped model's list
RADIUS_M = FUTILE_PUSH_RADIUS_M  # the radius to use when on: 1 cm (5 cells at 0.002 m), the episode memory's


class FutilePushes(Rule):
    """Rule "futile_pushes[:RADIUS_M]": pushes (rotation index, x, y in `world` metres) that changed nothing around
    the target in the current trial, suppressed in Q_p within `radius_m` (default RADIUS_M)."""

    name = "futile_pushes"
    order = 30
    option = PolicyOption("futile_push_radius", "float", "a push that changed nothing around the target is not "
                          "repeated in its direction within this radius (m) in the same trial; 0 removes the rule",
                          metavar="M", rule="futile_pushes", off=0.0)
    primitive = "push"
    kind = "memory"

    def __init__(self, rotations: int, radius_m: float = RADIUS_M) -> None:
        if radius_m < 0:
            raise ValueError(f"futile-push radius must be >= 0 m, got {radius_m}")
        self.rotations = rotations
        self.radius_m = radius_m
        self.pushes: list[tuple[int, float, float]] = []

    @classmethod
    def from_arg(cls, geometry: Geometry, arg: str | None) -> FutilePushes:
        return cls(geometry.heightmap.rotations, RADIUS_M if arg is None else parse_radius(cls.name, arg))

    def arg(self) -> str | None:
        return f"{self.radius_m:g}"

    def clear(self) -> None:
        self.pushes = []

    def reset(self) -> None:
        self.clear()

    def observe(self, last: Any, before: RuleContext, after: RuleContext) -> None:
        if last.primitive == "push":
            self.observe_push(last.rotation, last.x, last.y, before.heightmap, after.heightmap, before.target)

    def adjust(self, q: np.ndarray, ctx: RuleContext) -> np.ndarray:
        return self.suppress(q, ctx.heightmap)

    def observe_push(self, rotation: int, x: float, y: float, before: Heightmap, after: Heightmap,
                     target_before: np.ndarray) -> bool:
        """Remember the push (rotation, x, y) if it did not change the scene around `target_before` ((H, W) bool
        mask in `before`) from heightmap `before` to `after`; True when it was futile. Raises ValueError on shape
        mismatch."""
        futile = not scene_changed(before, after, target_before, radius_m=PUSH_CHANGE_RADIUS_M)
        if futile:
            self.pushes.append((int(rotation), float(x), float(y)))
        return futile

    def suppress(self, q_push: np.ndarray, hm: Heightmap) -> np.ndarray:
        """A float copy of the (R, H, W) push Q map with -inf at every remembered push's rotation within `radius_m`
        of its (x, y); the input itself when nothing is remembered or the radius is 0."""
        return suppress_near(q_push, hm, [((r,), x, y) for r, x, y in self.pushes], self.radius_m)
