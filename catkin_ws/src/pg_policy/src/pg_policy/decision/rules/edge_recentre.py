"""A geometric push of its own near the workspace edge: carry the target itself back towards the middle.

Most targets lost on the household families leave the workspace from within 8 cm of its edge (docs/RESULTS.md,
"Targets near the edge"): a push next to the target levers it sideways, a lying cup or a fruit rolls on after the
push, a missed grasp throws it. The edge guard (pg_policy.decision.rules.edge_guard) refuses the pushes it predicts
will carry the target out, but it passes pushes whose rigid prediction stays inside. This rule offers the one push
that moves the target away from the edge on purpose: while the target is visible and its centre lies within
`near_m` of a side of the workspace box (pg_core.geometry, `world` metres), the pushes along the inward normal of
the near side(s) (the rotations within MAX_ANGLE_DEG of it, the nearest first) that start just behind the target
(the closed fingers GAP_M behind its outermost cell along the push, through the median of its cells across it, and
OFFSETS_M beside that) are raised to the top of Q_p, above the net's best value. They still face every push check
(pg_policy.decision.rules.pipeline): one whose fingers would come down on an object (the landing test of
pg_policy.decision.rules.push_landing, applied here too) or outside the push region is not raised at all. The
rule changes nothing when the policy grasps: the grasp-or-push decision reads Q_g alone. As the test-time rule
"edge_recentre[:NEAR_M]" (kind "override") it is off in the shipped model's list; option `--edge-recentre on`.
A test-time deviation from the paper (docs/ARCHITECTURE.md).
"""

from __future__ import annotations

import math

import numpy as np

from pg_core.geometry import Geometry
from pg_core.heightmap import cell_centres, rotation_yaw, world_to_pixel
from pg_policy.decision.option import PolicyOption
from pg_policy.decision.rules.push_landing import LandingGuard
from pg_policy.decision.rules.rule import Rule, RuleContext, parse_metres

NEAR_M = 0.08  # a target whose centre lies this close to a side of the workspace (m) is carried back in
MAX_ANGLE_DEG = 25.0  # pushes within this angle of the inward normal count (16 rotations: the nearest one or two)
GAP_M = 0.004  # the closed fingers start this far (m) behind the target's outermost cell, past their half-thickness
OFFSETS_M = (0.0, -0.01, 0.01)  # start points across the push, beside the median of the target's cells (m)
RAISE = 1e-3  # the raised candidates sit this far apart above Q_p's best value, the preferred one highest


class EdgeRecentre(Rule):
    """Rule "edge_recentre[:NEAR_M]": near the workspace edge, push the target itself inwards (module docstring)."""

    name = "edge_recentre"
    order = 55
    kind = "override"
    option = PolicyOption("edge_recentre", "switch", "when the target lies within 8 cm of the workspace edge and the "
                          "policy pushes, push the target itself back inwards from behind it: on or off",
                          rule="edge_recentre")
    primitive = "push"

    def __init__(self, geometry: Geometry, near_m: float = NEAR_M) -> None:
        if near_m < 0:
            raise ValueError(f"edge_recentre needs near_m >= 0, got {near_m}")
        ws = geometry.workspace
        self.lo = np.array([ws.x[0], ws.y[0]], dtype=float)
        self.hi = np.array([ws.x[1], ws.y[1]], dtype=float)
        self.near = near_m
        self.rotations = geometry.heightmap.rotations
        self.behind = geometry.gripper.finger_size[0] / 2 + GAP_M  # start: finger centre behind the target (m)
        self.landing = LandingGuard(geometry)

    @classmethod
    def from_arg(cls, geometry: Geometry, arg: str | None) -> Rule:
        return cls(geometry, NEAR_M if arg is None else parse_metres(cls.name, arg, "distance from the edge"))

    def arg(self) -> str | None:
        return None if self.near == NEAR_M else f"{self.near:g}"

    def inward(self, centre: np.ndarray) -> np.ndarray | None:
        """The unit inward normal (2,) of the workspace sides within near_m of `centre` (x, y in m; a corner: the
        diagonal), None when no side is that near."""
        n = (centre - self.lo < self.near).astype(float) - (self.hi - centre < self.near).astype(float)
        norm = float(np.hypot(*n))
        return None if norm == 0.0 else n / norm

    def candidates(self, ctx: RuleContext) -> list[tuple[int, int, int]]:
        """The recentring pushes (rotation, row, col) of this context, preferred first: starting in the push region
        with the closed fingers landing on no object. [] when the rule has nothing to offer (`adjust` raises those
        whose Q_p value is finite)."""
        if not ctx.visible or not ctx.target.any():
            return []
        hm = ctx.heightmap
        t_xy = cell_centres(*np.nonzero(ctx.target), hm.bounds, hm.resolution)
        n = self.inward(t_xy.mean(axis=0))
        if n is None:
            return []
        yaws = rotation_yaw(np.arange(self.rotations), self.rotations)
        d = yaws - math.atan2(n[1], n[0])
        off = np.abs(np.arctan2(np.sin(d), np.cos(d)))  # (R,) rad between each rotation's yaw and the normal
        out = []
        for r in np.argsort(off, kind="stable"):
            if math.degrees(off[r]) > MAX_ANGLE_DEG:
                break
            u = np.array([math.cos(yaws[r]), math.sin(yaws[r])])
            v = np.array([-u[1], u[0]])
            s0 = float((t_xy @ u).min()) - self.behind
            v0 = float(np.median(t_xy @ v))
            for dv in OFFSETS_M:
                x, y = s0 * u + (v0 + dv) * v
                row, col = world_to_pixel(float(x), float(y), hm.bounds, hm.resolution)
                if not (0 <= row < hm.height.shape[0] and 0 <= col < hm.height.shape[1]):
                    continue
                if ctx.push_region[row, col] and self.landing.allows(hm.height, int(r), row, col):
                    out.append((int(r), row, col))
        return out

    def adjust(self, q: np.ndarray, ctx: RuleContext) -> np.ndarray:
        found = [c for c in self.candidates(ctx) if np.isfinite(q[c])]
        if not found:
            return q
        best = float(q[ctx.push_region[None] & np.isfinite(q)].max())
        out = q.copy()
        for i, c in enumerate(found):
            out[c] = best + RAISE * (len(found) - i)
        return out
