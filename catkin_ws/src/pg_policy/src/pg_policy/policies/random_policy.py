"""The `random` baseline: a uniformly random primitive, rotation and cell near the target."""

from __future__ import annotations

from typing import Any

import numpy as np

from pg_core.heightmap import OBJECT_HEIGHT_M
from pg_core.target_mask import dilate_mask
from pg_policy.decision.decision import Decision
from pg_policy.policies.policy import PolicyBase, observed_target

RANDOM_RADIUS_M = 0.02  # cells drawn within the target mask grown by this


class RandomPolicy(PolicyBase):
    """Uniformly random primitive, rotation and cell, the cell drawn within the target mask grown by
    RANDOM_RADIUS_M (any object cell when the target is not visible); seeded by reset(seed)."""

    name = "random"

    def act(self, obs: Any) -> Decision:
        hm = obs.heightmap
        target = observed_target(obs)
        region = dilate_mask(target, hm.resolution, RANDOM_RADIUS_M) if target.any() else hm.height > OBJECT_HEIGHT_M
        cells = np.argwhere(region)
        if len(cells) == 0:
            cells = np.argwhere(np.ones_like(hm.valid, dtype=bool))
        row, col = cells[int(self.rng.integers(len(cells)))]
        primitive = ("grasp", "push")[int(self.rng.integers(2))]
        return self.decision(hm, primitive, int(self.rng.integers(self.rotations)), int(row), int(col))
