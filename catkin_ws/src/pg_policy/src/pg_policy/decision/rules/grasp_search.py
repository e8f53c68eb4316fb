"""Grasps the nets rank low: across a vessel's wall, or on a wide target's raised part, offered when none of Q_g's
best cells passes the grasp checks.

A bowl, cup or mug is held by a grasp that straddles its wall with one finger inside, closing across the wall along
its normal (the grasp check's rim grasps, pg_policy.decision.rules.grasp_check; `pushgrasp scene grasp-probe bowl
cup mug --off-normal 0`: 90 of 96 such grasps hold a lone training vessel). The nets rank those cells and rotations
low: on a lone wide bowl none of Q_g's best TOP_K candidates passes the check, the check vetoes, and the policy
pushes the bowl about until its push budget forces a grasp (docs/RESULTS.md, "Where the household losses are").

A bowl lying upside down, twice as wide as the open jaw, is held by its foot ring, with the fingertips just above
the bowl (pg_core.action_geometry.raised_part; an inverted training bowl is lifted by grasps 3 or 6 mm under the
foot's top); its foot's centre is one cell among the bowl's thousands, which the nets rank low too.

As the test-time rule "grasp_search" (kind "check", pg_policy.decision.rules.rule) it has no test of its own: while
the target is visible it proposes candidates (Rule.proposals), which the pipeline asks with the map's tests (the
grasp check's among them) only when none of the best cells passes. Rim candidates are the target's cells within
`grasp_rim_reach` (half the open jaw) of the target mask's border, every STRIDE-th row and column, where something
within that reach stands a `grasp_rim_step` above the cell (a wall nearby: the cheap part of
pg_core.action_geometry.rim_pit), each at the two rotations whose closing line lies nearest the border's normal
there (the gradient of the mask's distance transform; for a vessel seen from above, the wall's normal). Part
candidates are the cells within PART_RADIUS_CELLS of the centroid of each of the PARTS largest pieces of the
target's top (its cells within `grasp_part_step` of its highest), every STRIDE-th row and column, at every rotation.
Only the candidates where the jaw line finds a pit (pg_core.action_geometry.rim_pit) whose wall stands
`grasp_rim_depth` (the pads' depth below the rim) or more above its floor, or a raised part (raised_part), are
proposed: a plate's low rim is left out (lone plates hold 4 of 32 rim grasps, `pushgrasp scene grasp-probe plate
--by-region`), and ordinary grasps the nets rank low stay unasked, so targets without a rim or a part (blocks) are
decided as without the rule. A test-time deviation from the paper (docs/ARCHITECTURE.md).
"""

from __future__ import annotations

import math
from collections.abc import Callable

import cv2
import numpy as np

from pg_core.action_geometry import raised_part, rim_pit
from pg_core.geometry import Geometry
from pg_core.heightmap import rotation_step, rotation_yaw
from pg_policy.decision.option import PolicyOption
from pg_policy.decision.rules.rule import Rule, RuleContext

STRIDE = 2  # candidates on every STRIDE-th row and column of the border band and around a part's centroid
PART_RADIUS_CELLS = 3  # part candidates lie this close to the centroid of a piece of the target's top (cells)
PARTS = 3  # the largest pieces of the target's top that get part candidates
NORMAL_BLUR_CELLS = 2.0  # sigma (cells) of the Gaussian smoothing the distance transform before its gradient


class GraspSearch(Rule):
    """Rule "grasp_search": propose grasps across the target's wall and on its raised parts when Q_g's best cells
    pass no test (module docstring)."""

    name = "grasp_search"
    order = 45
    kind = "check"
    option = PolicyOption("grasp_search", "switch", "when no grasp among Q_g's best passes the checks, also ask "
                          "grasps across the target's wall along its normal (a bowl's, cup's or mug's rim) and on "
                          "its raised parts (an upturned bowl's foot): on or off", rule="grasp_search")
    primitive = "grasp"

    def __init__(self, geometry: Geometry, stride: int = STRIDE) -> None:
        if stride < 1:
            raise ValueError(f"grasp_search needs stride >= 1, got {stride}")
        self.prims = geometry.primitives
        self.rotations = geometry.heightmap.rotations
        self.stride = stride

    def proposals(self, ctx: RuleContext) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
        if not ctx.visible or not ctx.target.any():
            return None
        found = [c for c in (self.rim_candidates(ctx), self.part_candidates(ctx)) if c is not None]
        if not found:
            return None
        return tuple(np.concatenate([c[i] for c in found]) for i in range(3))  # type: ignore[return-value]

    def rim_candidates(self, ctx: RuleContext) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
        """Rim candidates (module docstring): (rotations, rows, cols) (K,) int arrays, None when there are none."""
        hm = ctx.heightmap
        step, reach_m = self.prims.grasp_rim_step, self.prims.grasp_rim_reach
        if step <= 0 or reach_m <= 0:
            return None
        reach = int(math.ceil(reach_m / hm.resolution - 1e-9))
        target = np.asarray(ctx.target, dtype=np.uint8)
        dist = cv2.distanceTransform(np.pad(target, 1), cv2.DIST_L2, 5)[1:-1, 1:-1]  # cells to the border
        height = np.asarray(hm.height, dtype=np.float32)
        wall_near = cv2.dilate(height, np.ones((2 * reach + 1, 2 * reach + 1), np.uint8)) >= height + step
        band = (dist > 0) & (dist <= reach) & wall_near & ctx.grasp_region
        grid = np.zeros_like(band)
        grid[::self.stride, ::self.stride] = True
        rows, cols = np.nonzero(band & grid)
        if rows.size == 0:
            return None
        smooth = cv2.GaussianBlur(dist, (0, 0), NORMAL_BLUR_CELLS)
        gy, gx = np.gradient(smooth)
        angle = np.arctan2(gy[rows, cols], gx[rows, cols])  # the border's normal (inwards): x along cols, y along rows
        r = np.round(angle / rotation_step(self.rotations)).astype(np.int64) % self.rotations
        rots = np.concatenate([r, (r + self.rotations // 2) % self.rotations])
        deep = self.prims.grasp_rim_depth

        def deep_pit(*args: object) -> bool:  # a wall the pads' full depth above the floor: no plate's low rim
            pit = rim_pit(*args)  # type: ignore[arg-type]
            return pit is not None and pit.rim - pit.floor >= deep

        return self._only(ctx, deep_pit, rots, np.concatenate([rows, rows]), np.concatenate([cols, cols]))

    def part_candidates(self, ctx: RuleContext) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
        """Part candidates (module docstring): (rotations, rows, cols) (K,) int arrays, None when there are none."""
        step = self.prims.grasp_part_step
        if step <= 0:
            return None
        height = np.asarray(ctx.heightmap.height, dtype=np.float32)
        target = np.asarray(ctx.target, dtype=bool)
        top = target & (height >= float(height[target].max()) - step)
        count, labels, stats, centroids = cv2.connectedComponentsWithStats(top.astype(np.uint8), connectivity=8)
        pieces = sorted(range(1, count), key=lambda k: -int(stats[k, cv2.CC_STAT_AREA]))[:PARTS]
        k = PART_RADIUS_CELLS
        dr, dc = np.mgrid[-k:k + 1:self.stride, -k:k + 1:self.stride]
        rows_all, cols_all = [], []
        for piece in pieces:
            cx, cy = centroids[piece]  # (col, row)
            rr, cc = np.rint(cy).astype(np.int64) + dr.ravel(), np.rint(cx).astype(np.int64) + dc.ravel()
            inside = (rr >= 0) & (rr < height.shape[0]) & (cc >= 0) & (cc < height.shape[1])
            rr, cc = rr[inside], cc[inside]
            keep = ctx.grasp_region[rr, cc]
            rows_all.append(rr[keep])
            cols_all.append(cc[keep])
        rows, cols = (np.concatenate(a) if a else np.zeros(0, np.int64) for a in (rows_all, cols_all))
        if rows.size == 0:
            return None
        n = self.rotations
        return self._only(ctx, lambda *args: raised_part(*args) is not None, np.repeat(np.arange(n), rows.size),
                          np.tile(rows, n), np.tile(cols, n))

    def _only(self, ctx: RuleContext, shape: Callable[..., bool], rots: np.ndarray, rows: np.ndarray,
              cols: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
        """The candidates where `shape` (called like pg_core.action_geometry.rim_pit and raised_part) finds its
        geometry along the jaw line: the proposals are rim and part grasps only, never ordinary ones the nets ranked
        low (those would change the decisions on targets with no rim or part, such as blocks); None when none is
        left."""
        hm = ctx.heightmap
        zmin = float(hm.bounds[2, 0])
        keep = np.array([shape(hm.height, int(rw), int(cl), float(rotation_yaw(int(rt), self.rotations)),
                               hm.resolution, self.prims, zmin, hm.color)
                         for rt, rw, cl in zip(rots, rows, cols, strict=True)], dtype=bool)
        return (rots[keep], rows[keep], cols[keep]) if keep.any() else None
