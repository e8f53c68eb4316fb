"""A geometric guard on the learned push: do not carry the target towards the edge of the workspace.

The workspace box (pg_core.geometry, `world` metres) bounds every commanded pose, and the heightmap covers
exactly that box: a target pushed to within a few centimetres of its edge is partly out of view and its grasps
are refused or clipped, and the push net (trained on scenes that rarely reach the edge) readily pushes it there;
most failed random-scene trials of the `jaw-walls` protocol ended that way (docs/RESULTS.md).

Prediction, per push candidate (rotation r: the closed fingers start at the cell centre and travel
prims.push_length along u = (cos yaw, sin yaw), yaw = r * 2 pi / R): the push moves the target's cluster, the
occupied cells (height > `occupied_m`) joined to the target's cells through gaps of at most `gap_cells` cells
(objects that touch it, directly or through others: in packed scenes the push net often shoves the whole pile).
The cluster's cells inside the finger corridor (|v offset| <= finger width / 2, 0 <= u offset <= push length) are
met at the nearest one, and the cluster, target included, is carried the rest of the way as one rigid body
(rotation, sliding and the pile breaking up ignored: an over-estimate for pushes into the pile's far side). A push
is refused when the target's predicted centre ends outside the workspace shrunk by `margin_m` and farther outside
it than now; and, when the target already lies beyond the margin and the push meets it, unless the push brings it
back by at least `inward_m` (along the edge, a pushed target turns and rolls and leaves: the rule's argument, in
metres, default INWARD_M; "edge_guard:0" allows such pushes). Within `near_m` of a side (the rule's second argument,
"edge_guard:INWARD:NEAR", default NEAR_M; 0: off) the same holds for the workspace shrunk by `near_m`: a push that
meets the target's cluster while its centre lies that close to a side must carry the centre back in by `inward_m`
(scissors pushed along the edge by their tip swing out, household-10 seed 1,000,019; 0 < near_m <= margin_m adds
nothing; off in the shipped list: on the training seeds 0.08 m completes no more trials, docs/RESULTS.md "The grasp
search shipped"). Pushes back inwards and pushes that miss the cluster stay allowed. While the target is hidden it
may lie under whatever the push meets (a plate over it carries it along), so the same test applies to the cluster
of the first occupied cell in the finger corridor, its centre standing for the target's. As the test-time rule
"edge_guard" (pg_policy.decision.rules.rule) it is a candidate test on Q_p: the pipeline re-ranks Q_p's best cells
of the push region by it and every other push rule together. A test-time deviation from the paper
(docs/ARCHITECTURE.md).
"""

from __future__ import annotations

import math

import numpy as np

from pg_core.geometry import Geometry
from pg_core.heightmap import OBJECT_HEIGHT_M, TOP_K, Heightmap, cell_centres, pixel_to_world, rotation_yaw
from pg_policy.decision.option import PolicyOption
from pg_policy.decision.rules.rule import CandidateTest, Rule, RuleContext, parse_metres

MARGIN_M = 0.03  # the predicted target centre should stay this far inside the workspace (the heuristic's edge_margin)
OCCUPIED_M = OBJECT_HEIGHT_M  # cells higher than this hold an object (pg_core.heightmap; the heuristic's `occupied`)
GAP_CELLS = 4  # objects this many cells (8 mm) apart or closer count as touching: the pusher closes such gaps
INWARD_M = 0.01  # a push that meets a target already beyond the margin must carry it back in by this much (m)
NEAR_M = 0.0  # a push that meets a target this close to a side (m) must carry it back in by inward_m (0: off)


class EdgeGuard(Rule):
    """Rule "edge_guard": a push must not carry the target out of the shrunk workspace (module docstring)."""

    name = "edge_guard"
    order = 60
    option = PolicyOption("edge_guard", "switch", "refuse pushes that would carry the target out of the workspace: "
                          "on or off", rule="edge_guard")
    primitive = "push"

    def __init__(self, geometry: Geometry, margin_m: float = MARGIN_M, top_k: int = TOP_K,
                 occupied_m: float = OCCUPIED_M, gap_cells: int = GAP_CELLS, inward_m: float = INWARD_M,
                 near_m: float = NEAR_M) -> None:
        if margin_m < 0 or top_k < 1 or gap_cells < 0 or inward_m < 0 or near_m < 0:
            raise ValueError(f"edge guard needs margin_m, inward_m, near_m >= 0, top_k >= 1 and gap_cells >= 0, got "
                             f"{margin_m}, {inward_m}, {near_m}, {top_k}, {gap_cells}")
        ws = geometry.workspace
        self.lo = np.array([ws.x[0], ws.y[0]]) + margin_m
        self.hi = np.array([ws.x[1], ws.y[1]]) - margin_m
        self.near = near_m
        self.near_lo = np.array([ws.x[0], ws.y[0]]) + near_m
        self.near_hi = np.array([ws.x[1], ws.y[1]]) - near_m
        self.length = geometry.primitives.push_length
        self.half_width = geometry.gripper.finger_size[1] / 2
        self.rotations = geometry.heightmap.rotations
        self.top_k, self.occupied, self.gap = top_k, occupied_m, gap_cells
        self.inward = inward_m

    @classmethod
    def from_arg(cls, geometry: Geometry, arg: str | None) -> Rule:
        """"INWARD" or "INWARD:NEAR" (metres); None: the defaults. ValueError naming the distance otherwise."""
        if arg is None:
            return cls(geometry)
        inward, _, near = arg.partition(":")
        return cls(geometry, inward_m=parse_metres(cls.name, inward, "inward distance"),
                   near_m=parse_metres(cls.name, near, "near distance") if near else NEAR_M)

    def arg(self) -> str | None:
        if self.near != NEAR_M:
            return f"{self.inward:g}:{self.near:g}"
        return None if self.inward == INWARD_M else f"{self.inward:g}"

    def outside(self, xy: np.ndarray, near: bool = False) -> float:
        """How far (m) the point `xy` lies outside the workspace shrunk by the margin (near: by near_m; 0 inside)."""
        lo, hi = (self.near_lo, self.near_hi) if near else (self.lo, self.hi)
        return float(np.linalg.norm(np.maximum(np.maximum(lo - xy, xy - hi), 0.0)))

    def cluster(self, height: np.ndarray, target: np.ndarray) -> np.ndarray:
        """(H, W) bool: the target's cells and the occupied cells of the (H, W) `height` map (m) joined to them
        through gaps of at most gap_cells cells (rounded up to even; 8-connected)."""
        occupied = (height > self.occupied) | target
        labels = self.labels(occupied)
        ids = np.unique(labels[target])
        return np.isin(labels, ids[ids > 0]) & occupied

    def labels(self, occupied: np.ndarray) -> np.ndarray:
        """(H, W) int labels of the (H, W) bool `occupied` cells joined through gaps of at most gap_cells cells
        (rounded up to even; 8-connected); 0 off the joined cells."""
        from scipy import ndimage

        grow = (self.gap + 1) // 2  # both sides grow: a gap of 2 * grow cells closes
        joined = ndimage.binary_dilation(occupied, iterations=grow) if grow else occupied
        return ndimage.label(joined, structure=np.ones((3, 3), bool))[0]

    def carried(self, c_xy: np.ndarray, start: np.ndarray, yaw: float) -> float:
        """Distance (m) a push from `start` along `yaw` carries the rigid body whose cells are the (M, 2) `c_xy`."""
        u = np.array([math.cos(yaw), math.sin(yaw)])
        rel = c_xy - start
        s, t = rel @ u, rel @ np.array([-u[1], u[0]])
        hit = (np.abs(t) <= self.half_width) & (s >= 0.0) & (s <= self.length)
        return float(self.length - s[hit].min()) if hit.any() else 0.0

    def allows(self, t_xy: np.ndarray, start: np.ndarray, yaw: float, c_xy: np.ndarray | None = None) -> bool:
        """Whether the push keeps the centre of the (M, 2) target cells `t_xy` inside the shrunk workspace or brings
        it closer, the target riding on its cluster's (K, 2) cells `c_xy` (default: the target alone)."""
        centre = t_xy.mean(axis=0)
        carry = self.carried(t_xy if c_xy is None else c_xy, start, yaw)
        after = centre + carry * np.array([math.cos(yaw), math.sin(yaw)])
        if carry > 0.0 and self.near > 0.0 and (near_now := self.outside(centre, near=True)) > 0.0:
            if self.outside(after, near=True) > near_now - self.inward:
                return False
        out, now = self.outside(after), self.outside(centre)
        if out <= 0.0:
            return True
        if carry > 0.0 and now > 0.0 and self.inward > 0.0:
            return out <= now - self.inward
        return out <= now + 1e-9

    def candidate_test(self, ctx: RuleContext) -> CandidateTest | None:
        if not ctx.visible:
            return self.hidden_test(ctx.heightmap)
        if not ctx.target.any():
            return None
        return self.target_test(ctx.heightmap, ctx.target)

    def hidden_test(self, hm: Heightmap) -> CandidateTest | None:
        """The yes/no test of a push candidate (rotation, row, col) in `hm` while the target is hidden: the cluster
        the push meets first (the occupied cells joined through gaps of at most gap_cells cells) stands for the
        target riding on it. None when no cell is occupied."""
        occupied = hm.height > self.occupied
        if not occupied.any():
            return None
        rows, cols = np.nonzero(occupied)
        xy, label = cell_centres(rows, cols, hm.bounds, hm.resolution), self.labels(occupied)[rows, cols]

        def allowed(r: int, row: int, col: int) -> bool:
            start = np.array(pixel_to_world(row, col, hm.bounds, hm.resolution))
            yaw = rotation_yaw(r, self.rotations)
            u = np.array([math.cos(yaw), math.sin(yaw)])
            rel = xy - start
            s, t = rel @ u, rel @ np.array([-u[1], u[0]])
            hit = (np.abs(t) <= self.half_width) & (s >= 0.0) & (s <= self.length)
            if not hit.any():
                return True
            met = xy[label == label[np.flatnonzero(hit)[np.argmin(s[hit])]]]
            return self.allows(met, start, yaw, met)

        return allowed

    def target_test(self, hm: Heightmap, target: np.ndarray) -> CandidateTest:
        """The yes/no test of a push candidate (rotation, row, col) in `hm` for the non-empty (H, W) bool `target`."""
        t_xy = cell_centres(*np.nonzero(target), hm.bounds, hm.resolution)
        c_xy = cell_centres(*np.nonzero(self.cluster(hm.height, target)), hm.bounds, hm.resolution)

        def allowed(r: int, row: int, col: int) -> bool:
            start = np.array(pixel_to_world(row, col, hm.bounds, hm.resolution))
            return self.allows(t_xy, start, rotation_yaw(r, self.rotations), c_xy)

        return allowed
