"""A hand-written geometric push/grasp rule: the baseline the learned policy has to beat.

Everything is computed on the heightmap (pg_core.heightmap: rows along y, columns along x, heights in metres
above the table) in `world` metres. Rotation index r means yaw = r * 2 pi / R (R = 16); a grasp at yaw closes the
fingers along u = (cos yaw, sin yaw), a push travels 0.13 m along u (DESIGN.md sections 3 and 4).

The rule, for a visible target:
0. If another object lies on the target (its cells inside the target's convex hull are higher than the target),
   grasp that object away first.
1. Grasp if some rotation is *free*: with the fingers open (max_opening between the pads) and centred on the
   target's extent along u, the region each finger occupies and sweeps while closing (finger width along v plus a
   margin, from the target's edge to the finger's outer face plus a margin) holds no cell of another object higher
   than the grasp height minus a tolerance, the target fits between the pads, and the target is (nearly) as wide in
   the central strip of the pads as anywhere between them (else the pads touch it off-centre and it squirts out:
   round or wedge-shaped targets are grasped through their widest part). Among free grasps (8 closing axes x grasp
   lines shifted by OFFSETS across them) the score favours clearance (distance from those regions to the nearest
   obstacle) up to `enough_clearance`, then a narrow width between the pads (pads parallel to the short faces, not
   across a long or tilted side), then a central grasp line.
2. Otherwise push the target out of the clutter: for each of the 16 directions d, the closed fingers start behind
   the target on the line through its centre (backing off until the start is free, else the direction is dropped),
   and the target is predicted to travel 0.13 m minus the free gap. A direction scores by whether a grasp across
   the push (fingers along the perpendicular of d, objects in the push corridor assumed to be carried along) would
   be free afterwards and by its clearance, the free run ahead of the target, a short back-off, and keeping the
   target inside the workspace.
3. After `declutter_after` pushes in a row without a free grasp (pushes that drag the blocking neighbour along,
   e.g. a target nested in an arch), grasp away the neighbour whose removal frees a grasp of the target (this costs
   one failed grasp attempt).
4. Target not visible: grasp (goal-agnostically) the most graspable object, preferring objects near where the target
   was last seen and high ones (something on top of the target), to uncover it.
Grasps that already failed at the same place and rotation are not repeated within a trial.

Degenerate masks (novel objects, partial views) never raise: no rule reduces over an empty selection.
- A target of fewer than `min_target_cells` cells (or none, whatever that parameter) is not visible (rule 4).
- A target mask in pieces far apart (several objects of the target's colour, stray cells) can have its mean between
  the pieces, so that the window examined around it holds no target cell: the rules then work on the mask's largest
  connected piece (`focus`). A rule that still finds no target cell in its window returns None (no action).
- Last resort (`fallback`), when no rule gives an action: a random push from a random occupied cell (keeps the trial
  moving).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from pg_core.action_geometry import grasp_z_at, grasp_z_for_height, push_z
from pg_core.geometry import Geometry
from pg_core.heightmap import Heightmap, rotation_yaw, world_to_pixel
from pg_core.palette import PALETTE
from pg_core.target_mask import target_mask
from pg_policy.decision.jaw_fit import CellWindow, JawFit, JawParams, dilate, mask_centre
from pg_policy.decision.rules.failed_grasps import DEFAULT_RADIUS_M as FAILED_GRASP_RADIUS_M

OFFSETS = (0.0, -0.006, 0.006, -0.012, 0.012, -0.018, 0.018, -0.024, 0.024, -0.03, 0.03)  # grasp line shifts (m)


@dataclass(frozen=True)
class HeuristicParams(JawParams):
    """Tunables (metres unless stated): the jaw-footprint test's (JawParams: margin, obstacle_tol, occupied, window,
    min_band_cells, centre_line, chord_tol) and the rule's own."""

    push_gap: float = 0.004  # first gap tried between the closed fingers and the target
    max_backoff: float = 0.10  # farthest start tried behind the target (over neighbours: they are pushed too)
    edge_margin: float = 0.03  # predicted target centre must stay this far inside the workspace
    enough_clearance: float = 0.01  # more clearance than this does not make a grasp better
    width_weight: float = 0.5  # score per metre of target width between the pads (narrow grasps are stabler)
    repeat_radius: float = FAILED_GRASP_RADIUS_M  # a failed grasp closer than this (same axis) is not repeated
    min_target_cells: int = 25  # fewer visible target cells: treated as not visible
    on_top: float = 0.01  # another object's cells this much above the target's top inside its hull lie on it
    declutter_after: int = 4  # pushes in a row after which a blocking neighbour is grasped away


@dataclass(frozen=True)
class Action:
    """A chosen primitive at heightmap cell (row, col) and rotation index; score is rule-internal; why: a note."""

    primitive: str
    rotation: int
    row: int
    col: int
    score: float
    why: str


class HeuristicPlanner:
    """The rule of the module docstring for one geometry; stateless apart from what `plan` is given."""

    def __init__(self, geometry: Geometry, params: HeuristicParams | None = None) -> None:
        self.g = geometry
        self.p = params or HeuristicParams()
        self.rotations = geometry.heightmap.rotations
        self.jaw = JawFit(geometry, self.p)
        self.half_open, self.finger_t, self.finger_w = self.jaw.half_open, self.jaw.finger_t, self.jaw.finger_w

    # -- helpers -----------------------------------------------------------------------------------------------
    def yaw(self, r: int) -> float:
        return rotation_yaw(r, self.rotations)

    def _pixel(self, hm: Heightmap, xy: np.ndarray) -> tuple[int, int] | None:
        r, c = world_to_pixel(float(xy[0]), float(xy[1]), hm.bounds, hm.resolution)
        if 0 <= r < hm.height.shape[0] and 0 <= c < hm.height.shape[1]:
            return r, c
        return None

    def _inside(self, xy: np.ndarray, margin: float) -> bool:
        ws = self.g.workspace
        return ws.x[0] + margin <= xy[0] <= ws.x[1] - margin and ws.y[0] + margin <= xy[1] <= ws.y[1] - margin

    # -- grasp ---------------------------------------------------------------------------------------------------
    def grasp_fit(self, t_xy: np.ndarray, o_xy: np.ndarray, o_h: np.ndarray, centre: np.ndarray, yaw: float,
                  z_grasp: float) -> tuple[float, np.ndarray, float] | None:
        """The jaw-footprint test (pg_policy.decision.jaw_fit.JawFit.grasp_fit) with this planner's parameters."""
        return self.jaw.grasp_fit(t_xy, o_xy, o_h, centre, yaw, z_grasp)

    def best_grasp(self, hm: Heightmap, obj: np.ndarray, others: np.ndarray, cells: CellWindow,
                   tabu: list[tuple[int, float, float]], rotations: list[int] | None = None) -> Action | None:
        """Best free grasp of the object cells `obj` ((H, W) bool) among `others` ((H, W) bool), or None."""
        o = obj[cells.slice].reshape(-1)
        if not o.any():
            return None
        t_xy = cells.xy[o]
        oth = others[cells.slice].reshape(-1)
        o_xy, o_h = cells.xy[oth], cells.h[oth]
        centroid = t_xy.mean(axis=0)
        half = self.rotations // 2
        best: Action | None = None
        for r in rotations if rotations is not None else range(half):
            yaw = self.yaw(r)
            v = np.array([-math.sin(yaw), math.cos(yaw)])
            for off in OFFSETS:
                centre = centroid + off * v
                pix = self._pixel(hm, centre)
                if pix is None or not obj[pix]:
                    continue
                zg = grasp_z_at(hm, pix[0], pix[1], self.g.primitives, yaw=yaw)
                fit = self.grasp_fit(t_xy, o_xy, o_h, centre, yaw, zg)
                if fit is None or fit[0] < 0:
                    continue
                pix2 = self._pixel(hm, fit[1])
                if pix2 is None or not obj[pix2] or not self._inside(fit[1], 0.0):
                    continue
                if any(rt % half == r % half and math.hypot(fit[1][0] - x, fit[1][1] - y) < self.p.repeat_radius
                       for rt, x, y in tabu):
                    continue
                # enough clearance, then the narrowest width (pads parallel to faces, not across a long or
                # tilted side), then a central grasp line
                score = min(fit[0], self.p.enough_clearance) - self.p.width_weight * fit[2] - 0.3 * abs(off)
                if best is None or score > best.score:
                    best = Action("grasp", r, pix2[0], pix2[1], score, f"free grasp, clearance {fit[0]:.3f} m")
        return best

    # -- push ----------------------------------------------------------------------------------------------------
    def best_push(self, hm: Heightmap, target: np.ndarray, cells: CellWindow) -> Action | None:
        """Best push of the target out of the clutter (module docstring, rule 2), or None if no start is free or no
        target cell lies in the window `cells`."""
        p, prims = self.p, self.g.primitives
        t = target[cells.slice].reshape(-1)
        if not t.any():  # nothing to push here (the target's extent along each direction would be undefined)
            return None
        occ = (cells.h > p.occupied) & ~dilate(target, 1)[cells.slice].reshape(-1)
        t_xy, o_xy, o_h = cells.xy[t], cells.xy[occ], cells.h[occ]
        c = t_xy.mean(axis=0)
        a = self.finger_t  # closed fingers: 2 x thickness along d, finger width along v
        b = self.finger_w / 2
        best: Action | None = None
        for k in range(self.rotations):
            yaw = self.yaw(k)
            d = np.array([math.cos(yaw), math.sin(yaw)])
            v = np.array([-d[1], d[0]])
            s_t, v_t = (t_xy - c) @ d, (t_xy - c) @ v
            back, front, w = float(s_t.min()), float(s_t.max()), float(np.abs(v_t).max())
            s_o, v_o = (o_xy - c) @ d, (o_xy - c) @ v
            start, delta, blocked_len, pix = None, p.push_gap, 0.0, None
            while delta <= p.max_backoff:
                sc = c + (back - a - delta) * d
                pix = self._pixel(hm, sc)
                if pix is None or not self._inside(sc, 0.0):
                    break
                zp = push_z(hm.height, pix[0], pix[1], prims, yaw=yaw, resolution=hm.resolution)  # as action_pose
                s0 = back - a - delta
                foot = (np.abs(s_o - s0) <= a + p.margin) & (np.abs(v_o) <= b + p.margin) & (o_h > zp - 0.002)
                if not foot.any():
                    start = sc
                    break
                blocked_len += 0.002
                delta += 0.002
            if start is None or pix is None:
                continue
            travel = max(prims.push_length - (delta - blocked_len), 0.0)
            corridor = np.abs(v_o) <= w + p.margin
            ahead = corridor & (s_o > front) & (s_o <= front + travel)
            free_run = float(s_o[ahead].min() - front) if ahead.any() else travel
            end = c + travel * d
            if not self._inside(end, p.edge_margin):
                continue
            moving = corridor & (s_o >= back - a - delta - p.margin)
            keep = ~moving
            post = self.grasp_fit(t_xy + travel * d, o_xy[keep], o_h[keep], end, yaw + math.pi / 2,
                                  grasp_z_for_height(float(np.median(cells.h[t])), prims))
            post_ok = post is not None and post[0] >= 0
            post_clear = min(post[0], 0.02) if post_ok else 0.0  # type: ignore[index]
            score = (2.0 * post_ok + 20.0 * post_clear + min(free_run, travel) / prims.push_length
                     - (delta - blocked_len) / prims.push_length - 0.3 * (blocked_len > 0))
            if best is None or score > best.score:
                best = Action("push", k, pix[0], pix[1], score,
                              f"push target out: travel {travel:.3f} m, free run {free_run:.3f} m, "
                              f"grasp after {'free' if post_ok else 'blocked'}")
        return best

    # -- other objects -------------------------------------------------------------------------------------------
    def blobs(self, hm: Heightmap, exclude: np.ndarray | None = None) -> list[tuple[str, np.ndarray, np.ndarray]]:
        """(colour name, (H, W) bool cells, centre (x, y) m) of each single-colour object region on the table."""
        import cv2


        occupied = hm.height > self.p.occupied
        if exclude is not None:
            occupied &= ~exclude
        out = []
        for name in PALETTE:
            mask = target_mask(hm.color, hm.valid, name) & occupied
            if mask.sum() < self.p.min_target_cells:
                continue
            n, labels = cv2.connectedComponents(mask.astype(np.uint8), connectivity=8)
            for i in range(1, n):
                blob = labels == i
                if blob.sum() >= self.p.min_target_cells:
                    out.append((name, blob, mask_centre(hm, blob)))
        return out

    def _grasp_of(self, hm: Heightmap, blob: np.ndarray, centre: np.ndarray,
                  tabu: list[tuple[int, float, float]]) -> Action | None:
        occupied = hm.height > self.p.occupied
        return self.best_grasp(hm, blob, occupied & ~dilate(blob, 1), CellWindow(hm, centre, self.p.window), tabu)

    def uncover(self, hm: Heightmap, last_seen: np.ndarray | None,
                tabu: list[tuple[int, float, float]]) -> Action | None:
        """Target hidden: the most graspable other object (by colour blob), near `last_seen` and high ones first."""
        best: Action | None = None
        for name, blob, centre in self.blobs(hm):
            act = self._grasp_of(hm, blob, centre, tabu)
            if act is None:
                continue
            near = 0.0 if last_seen is None else float(np.linalg.norm(centre - last_seen))
            score = float(hm.height[blob].max()) - 0.5 * near + act.score
            if best is None or score > best.score:
                best = Action("grasp", act.rotation, act.row, act.col, score, f"uncover: grasp {name} object")
        return best

    def remove_on_top(self, hm: Heightmap, target: np.ndarray,
                      tabu: list[tuple[int, float, float]]) -> Action | None:
        """Something lies on the target (higher cells of another object inside the target's convex hull): grasp the
        object that covers most of those cells away; None when nothing lies on it or it cannot be grasped."""
        import cv2

        pts = np.argwhere(target)[:, ::-1].astype(np.int32)  # (col, row)
        hull = np.zeros(target.shape, np.uint8)
        cv2.fillConvexPoly(hull, cv2.convexHull(pts), 1)
        top = float(np.median(hm.height[target]))
        over = hull.astype(bool) & ~dilate(target, 1) & (hm.height > top + self.p.on_top)
        if over.sum() < self.p.min_target_cells:
            return None
        best: Action | None = None
        for name, blob, centre in self.blobs(hm, exclude=dilate(target, 1)):
            cover = int((blob & over).sum())
            if cover < self.p.min_target_cells:
                continue
            act = self._grasp_of(hm, blob, centre, tabu)
            if act is not None and (best is None or cover > best.score):
                best = Action("grasp", act.rotation, act.row, act.col, cover, f"remove {name} object on the target")
        return best

    def remove_blocker(self, hm: Heightmap, target: np.ndarray, cells: CellWindow,
                       tabu: list[tuple[int, float, float]]) -> Action | None:
        """Grasp (and so remove) the neighbour whose absence frees a grasp of the target; None if there is none."""
        occupied = hm.height > self.p.occupied
        near = dilate(target, int(round(0.02 / hm.resolution)))
        best: Action | None = None
        for name, blob, centre in self.blobs(hm, exclude=dilate(target, 1)):
            if not (blob & near).any():
                continue
            after = self.best_grasp(hm, target, occupied & ~dilate(target, 1) & ~dilate(blob, 1), cells, [])
            if after is None:
                continue
            act = self._grasp_of(hm, blob, centre, tabu)
            if act is not None and (best is None or act.score + after.score > best.score):
                best = Action("grasp", act.rotation, act.row, act.col, act.score + after.score,
                              f"remove blocking {name} object")
        return best

    def fallback(self, hm: Heightmap, rng: np.random.Generator) -> Action:
        """Nothing sensible: push from a random occupied cell in a random direction (keeps the trial moving)."""
        occ = np.argwhere(hm.height > self.p.occupied)
        if len(occ) == 0:
            occ = np.argwhere(np.ones_like(hm.valid))
        r, c = occ[int(rng.integers(len(occ)))]
        return Action("push", int(rng.integers(self.rotations)), int(r), int(c), -1e9, "fallback: random push")

    # -- top level -------------------------------------------------------------------------------------------------
    def visible(self, target: np.ndarray) -> bool:
        """Whether the target mask counts as visible: at least `min_target_cells` cells, and at least one."""
        n = int(target.sum())
        return n > 0 and n >= self.p.min_target_cells

    @staticmethod
    def largest_piece(target: np.ndarray) -> np.ndarray:
        """The largest 8-connected piece of the non-empty (H, W) bool mask."""
        import cv2

        n, labels, stats, _ = cv2.connectedComponentsWithStats(target.astype(np.uint8), connectivity=8)
        if n <= 2:
            return target
        return labels == 1 + int(np.argmax(stats[1:, cv2.CC_STAT_AREA]))

    def focus(self, hm: Heightmap, target: np.ndarray) -> tuple[np.ndarray, CellWindow, np.ndarray]:
        """(target, window, other objects' cells) the rules work on for a visible target: the whole mask, or its
        largest piece when the window around the whole mask holds no target cell (pieces far apart: module
        docstring)."""
        cells, others = self.around(hm, target)
        if not target[cells.slice].any():
            target = self.largest_piece(target)
            cells, others = self.around(hm, target)
        return target, cells, others

    def push_of(self, hm: Heightmap, target: np.ndarray) -> Action | None:
        """The rule's push of a visible target (rule 2) whether or not a grasp is free; None when the target has
        fewer than `min_target_cells` cells or no push start is free. Used to guide exploration in training."""
        if not self.visible(target):
            return None
        target, cells, _ = self.focus(hm, target)
        return self.best_push(hm, target, cells)

    def grasp_of(self, hm: Heightmap, target: np.ndarray) -> Action | None:
        """The rule's free grasp of a visible target (rule 1), None when there is none or the target has fewer than
        `min_target_cells` cells. Used to guide exploration in training."""
        if not self.visible(target):
            return None
        target, cells, others = self.focus(hm, target)
        return self.best_grasp(hm, target, others, cells, [])

    def around(self, hm: Heightmap, target: np.ndarray) -> tuple[CellWindow, np.ndarray]:
        """The examined window around a visible (non-empty) target and the (H, W) bool cells of other objects."""
        return self.jaw.around(hm, target)

    def guide(self, primitive: str, hm: Heightmap, target: np.ndarray) -> Action | None:
        """`push_of` or `grasp_of` by primitive name."""
        return self.push_of(hm, target) if primitive == "push" else self.grasp_of(hm, target)

    def plan(self, hm: Heightmap, target: np.ndarray, tabu: list[tuple[int, float, float]],
             last_seen: np.ndarray | None, rng: np.random.Generator, pushes_in_row: int = 0) -> Action:
        """The action of the rule (module docstring) for a target mask ((H, W) bool, possibly empty).

        pushes_in_row: pushes since the last grasp (from `declutter_after` on, a blocking neighbour may be removed).
        """
        visible = self.visible(target)
        if visible:
            target, cells, others = self.focus(hm, target)
            act = self.remove_on_top(hm, target, tabu)
            if act is None:
                act = self.best_grasp(hm, target, others, cells, tabu)
            if act is None and pushes_in_row >= self.p.declutter_after:
                act = self.remove_blocker(hm, target, cells, tabu)
            if act is None:
                act = self.best_push(hm, target, cells)
            if act is not None:
                return act
        act = self.uncover(hm, last_seen, tabu)
        return act if act is not None else self.fallback(hm, rng)
