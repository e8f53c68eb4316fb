"""A geometric check of the learned push: the closed fingers must not come down on top of an object.

The push primitive lowers the closed fingers at the start cell to pg_core.action_geometry.push_z (the local max
height within push_window_px cells minus push_depth) and then travels. The closed jaw's footprint is a square of
2 x finger thickness along the push direction by the finger width across it, centred at the start cell, and it
spans the same cells as that window: when the fingers start beside an object they come down over its edge, which
the push was trained with; when they start over an object they press push_depth into its top under position
control, and the simulator's contact solver throws it (most of the packed failures of docs/RESULTS.md: a cube
launched 0.3 m up, an upright cylinder tipped over). A push is refused when more than `max_cover` of its footprint
cells stand higher than the fingertips (push z + `tol_m`). As the test-time rule "push_landing"
(pg_policy.decision.rules.rule) it is a candidate test on Q_p while the target is visible: the pipeline re-ranks Q_p's
best cells of the push region by it and every other push rule together. It is a preference (kind "preference"):
in a packed pile every one of the best pushes may start over an object, and then the other push rules decide alone
(the push net's best push that the edge guard passes), as the packed scenes need pushes into the pile. A test-time
deviation from the paper (docs/ARCHITECTURE.md).
"""

from __future__ import annotations

import math

import numpy as np

from pg_core.action_geometry import push_z
from pg_core.geometry import Geometry
from pg_core.heightmap import TOP_K, rotation_yaw
from pg_policy.decision.option import PolicyOption
from pg_policy.decision.rules.rule import CandidateTest, Rule, RuleContext

MAX_COVER = 0.25  # at most this fraction of the closed jaw's footprint may lie on something above the fingertips
TOL_M = 0.002  # a cell counts as under the fingers when it stands this much above the fingertips


class LandingGuard(Rule):
    """Rule "push_landing": a push must not start on top of an object (module docstring)."""

    name = "push_landing"
    order = 50
    kind = "preference"  # in a dense pile every push starts over an object: then the push guards' other tests decide
    option = PolicyOption("push_landing", "switch", "prefer pushes whose closed fingers do not come down on top of an "
                          "object (while one passes the other push rules): on or off", rule="push_landing")
    primitive = "push"

    def __init__(self, geometry: Geometry, max_cover: float = MAX_COVER, tol_m: float = TOL_M,
                 top_k: int = TOP_K) -> None:
        if not 0.0 <= max_cover <= 1.0 or top_k < 1:
            raise ValueError(f"landing guard needs 0 <= max_cover <= 1 and top_k >= 1, got {max_cover}, {top_k}")
        self.prims = geometry.primitives
        self.max_cover, self.tol, self.top_k = max_cover, tol_m, top_k
        self.res = res = geometry.heightmap.resolution
        self.rotations = geometry.heightmap.rotations
        half_u, half_v = geometry.gripper.finger_size[0], geometry.gripper.finger_size[1] / 2  # closed jaw, m
        n = int(math.ceil(max(half_u, half_v) * math.sqrt(2) / res))
        dr, dc = np.mgrid[-n:n + 1, -n:n + 1]
        xy = np.stack([dc.ravel(), dr.ravel()], axis=1) * res  # cell offsets in m: +col = +x, +row = +y
        self.footprints = []  # per rotation: (K, 2) int (row, col) offsets of the cells under the closed jaw
        for r in range(geometry.heightmap.rotations):
            yaw = rotation_yaw(r, geometry.heightmap.rotations)
            u = np.array([math.cos(yaw), math.sin(yaw)])
            inside = (np.abs(xy @ u) <= half_u + 1e-9) & (np.abs(xy @ np.array([-u[1], u[0]])) <= half_v + 1e-9)
            self.footprints.append(np.stack([dr.ravel()[inside], dc.ravel()[inside]], axis=1))

    def cover(self, height: np.ndarray, rotation: int, row: int, col: int) -> float:
        """Fraction of the closed jaw's footprint at (row, col) and `rotation` whose cells of the (H, W) `height`
        map (m) stand more than tol_m above the push's fingertip z (cells off the map count as free)."""
        off = self.footprints[rotation]
        rr, cc = off[:, 0] + row, off[:, 1] + col
        on = (rr >= 0) & (rr < height.shape[0]) & (cc >= 0) & (cc < height.shape[1])
        z = push_z(height, row, col, self.prims, yaw=rotation_yaw(rotation, self.rotations), resolution=self.res)
        return float((height[rr[on], cc[on]] > z + self.tol).sum()) / len(off)

    def allows(self, height: np.ndarray, rotation: int, row: int, col: int) -> bool:
        return self.cover(height, rotation, row, col) <= self.max_cover

    def candidate_test(self, ctx: RuleContext) -> CandidateTest | None:
        if not ctx.visible:
            return None
        height = ctx.heightmap.height
        return lambda r, row, col: self.allows(height, r, row, col)
