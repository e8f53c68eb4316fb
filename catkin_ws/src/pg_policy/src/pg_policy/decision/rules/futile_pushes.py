"""Within-trial memory of pushes that changed nothing, so a deterministic greedy policy does not repeat one.

A push that leaves the scene around the target unchanged (pg_policy.training.rewards.scene_changed with the trainer's
``PUSH_CHANGE_RADIUS_M``, the rule that gives such a push R_p = -0.5 in training) leaves the heightmap, and with it
the argmax of Q_p, where it was: the learned policy then pushed at the same cell and rotation again, up to six times
in a row, typically at the workspace edge where the push end is clipped (docs/RESULTS.md). Suppressing that push
direction within `radius_m` of where it started makes the next push try something else. Unlike a grasp, a push is
not symmetric: only its own rotation index is suppressed.
"""

from __future__ import annotations

import numpy as np

from pg_core.heightmap import Heightmap
from pg_policy.decision.rules.failed_grasps import suppress_near
from pg_policy.training.rewards import PUSH_CHANGE_RADIUS_M, scene_changed

DEFAULT_RADIUS_M = 0.0  # off by default until the protocol is re-run with it (results/experiments/futile_pushes)
RADIUS_M = 0.01  # the radius to use when on: 1 cm (5 cells at 0.002 m)


class FutilePushes:
    """Pushes (rotation index, x, y in `world` metres) that changed nothing around the target in the current trial."""

    def __init__(self, rotations: int, radius_m: float = RADIUS_M) -> None:
        if radius_m < 0:
            raise ValueError(f"futile-push radius must be >= 0 m, got {radius_m}")
        self.rotations = rotations
        self.radius_m = radius_m
        self.pushes: list[tuple[int, float, float]] = []

    def clear(self) -> None:
        self.pushes = []

    def observe(self, rotation: int, x: float, y: float, before: Heightmap, after: Heightmap,
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
