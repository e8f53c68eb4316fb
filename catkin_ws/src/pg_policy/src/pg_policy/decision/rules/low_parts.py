"""A preference of the learned grasp: close the jaw on a thin object's raised parts, not on its lowest ones.

Thin tools lying on the table (knives, forks, spoons, scissors, spatulas) have parts a few millimetres high (blades,
tines, a spoon's bowl rim, scissor blades) and raised ones (handles, finger rings). The grasp height rule sends the
fingertips to `primitives.grasp_low_min_z` (1.5 mm) on the low parts, and a jaw closing there mostly closes on air
or squeezes the part out: grasps at the cells a policy picks, each tool alone on the table
(`python -m pg_sim.world.grasp_probe knife spoon fork scissors --by-region`), lift the object from raised cells
(5 mm or more above the table) 50-94 % of the time by category and from lower ones 0-42 %; in the household
families, target grasps at a 1.5 mm fingertip height lift the target 13 times in 60.

A grasp candidate (rotation, row, col) passes when its cell stands at least `min_height_m` above the table, or the
grasp is a rim grasp (pg_core.action_geometry.rim_pit: a vessel's floor next to its wall, where the fingertips go
below the rim, not to the floor). As the test-time rule "low_parts" (kind "preference",
pg_policy.decision.rules.rule) it is a candidate test on Q_g while the target is visible, and only a preference: the
pipeline re-ranks Q_g's best cells of the grasp region by it and the grasp checks together, and by the checks alone
when no candidate passes it (a target that is low everywhere, or whose raised parts fail the jaw check), so it never
vetoes a grasp. A test-time deviation from the paper (docs/ARCHITECTURE.md).
"""

from __future__ import annotations

import numpy as np

from pg_core.action_geometry import rim_pit
from pg_core.geometry import Geometry
from pg_core.heightmap import TOP_K, rotation_yaw
from pg_policy.decision.option import PolicyOption
from pg_policy.decision.rules.rule import BatchTest, CandidateTest, Rule, RuleContext, parse_metres

MIN_HEIGHT_M = 0.005  # raised parts: cells this far above the table or higher (the grasp probe's high/low split)


class LowParts(Rule):
    """Rule "low_parts": prefer grasps at cells `min_height_m` or more above the table (module docstring)."""

    name = "low_parts"
    order = 35
    kind = "preference"
    option = PolicyOption("low_parts", "switch", "prefer grasps on a thin object's raised parts (handles, rings) over "
                          "its low ones (blades, tines), where the jaw closes on air: on or off", rule="low_parts")
    primitive = "grasp"

    def __init__(self, geometry: Geometry, min_height_m: float = MIN_HEIGHT_M, top_k: int = TOP_K) -> None:
        if min_height_m < 0 or top_k < 1:
            raise ValueError(f"low_parts needs min_height_m >= 0 and top_k >= 1, got {min_height_m}, {top_k}")
        self.prims = geometry.primitives
        self.rotations = geometry.heightmap.rotations
        self.min_height, self.top_k = min_height_m, top_k

    @classmethod
    def from_arg(cls, geometry: Geometry, arg: str | None) -> Rule:
        height = MIN_HEIGHT_M if arg is None else parse_metres(cls.name, arg, "least height of a raised part")
        return cls(geometry, min_height_m=height)

    def arg(self) -> str | None:
        return None if self.min_height == MIN_HEIGHT_M else f"{self.min_height:g}"

    def candidate_test(self, ctx: RuleContext) -> CandidateTest | None:
        if not ctx.visible or not ctx.target.any():
            return None
        hm = ctx.heightmap
        height, zmin = hm.height, float(hm.bounds[2, 0])

        def many(rots: np.ndarray, rows: np.ndarray, cols: np.ndarray) -> np.ndarray:
            ok = height[rows, cols] + zmin >= self.min_height
            for i in np.flatnonzero(~ok):  # low cells: a rim grasp passes
                yaw = rotation_yaw(int(rots[i]), self.rotations)
                ok[i] = rim_pit(height, int(rows[i]), int(cols[i]), yaw, hm.resolution, self.prims, zmin,
                                hm.color) is not None
            return ok

        return BatchTest(many)
