"""A geometric check of the learned grasp: the jaw-footprint test (pg_policy.decision.jaw_fit) on Q_g's best cells.

Q_g is an (R, H, W) float map over R rotations (rotation r: the fingers close along yaw = r * 2 pi / R) and the
heightmap's cells (pg_core.heightmap; heights in metres above the table). As the test-time rule "grasp_check:VARIANT"
(pg_policy.decision.rules.rule) it is a candidate test on Q_g while the target is visible: the pipeline walks the grasp
region's cells in descending Q_g (at most `top_k`) and keeps the first whose grasp passes the jaw model's `grasp_fit` at
that cell and yaw: the target fits between the open pads, it is as wide in the pads' central strip as anywhere between
them (else a round or wedge-shaped target squirts out), no neighbour stands in a finger's sweep, and the cell lies
within `centre_tol_m` of the pad-centred grasp line. A grasp that fails so passes when it passes with the target's cells
lower than the fingertips by the jaw model's obstacle tolerance left out, for the walls below too: the pads pass over
them (a handle lying flat beside a mug's body). Leaving them out never refuses a grasp the whole target passes (a short
object deep in a vessel, under the fingertips whole). It only re-ranks: the passing cell takes the best value and the
cells ranked above it get -inf, so the grasp-or-push decision (masked max vs the threshold) is the same as without the
check. When no candidate passes, Q_g is unchanged; the strict variants ("jaw-strict", "jaw-walls") then ask the policy
to push instead of grasping, as the heuristic baseline does when it finds no free grasp. "jaw-walls" is "jaw-strict"
that also demands walls where the pads touch: the target's highest cell within `wall_window_m` of each end of its extent
between the pads must stand at least `wall_tol_m` above the fingertips (the grasp z). A top-down heightmap sees the
silhouette's edge at the height of the target's widest part, so a low edge means the target narrows above the fingertips
(a half cylinder or a wedge lying flat): the pads would meet a slope and squeeze it down and out. A test-time deviation
from the paper (docs/ARCHITECTURE.md); "jaw-walls" is in the shipped model's rule list.

Rim grasps: a candidate cell of the target that lies in a pit along the closing line (pg_core.action_geometry.rim_pit:
a bowl's, cup's or mug's floor or inner wall next to its wall) passes without the footprint and wall tests when no
neighbour stands in a finger's sweep: the jaw straddles the wall, one finger inside the vessel (DESIGN.md section 4),
so a vessel wider than the open jaw can still be grasped (the footprint test alone refuses every grasp of it).
Likewise a candidate on a raised part of a target wider than the open jaw (pg_core.action_geometry.raised_part: the
foot ring of a bowl upside down, the fingertips just above the bowl) passes when no neighbour stands in a finger's
sweep. In
the variant "jaw-walls-normal" ("jaw-walls" otherwise) the closing line must cross the wall within
RIM_MAX_ANGLE_DEG of its normal (the slope of the heightmap, smoothed over WALL_BLUR_CELLS, where the line meets
the nearer wall). Probed on lone training bowls, cups and mugs (`pushgrasp scene grasp-probe bowl cup mug
--off-normal 0,1,2,3`, its rim and wall cells, 32 grasps per vessel and angle), grasps along the wall's normal hold
90 of 96, 22.5 degrees off 81, 45 degrees off 36 (bowls 31 of 32, cups 0, mugs 5), 67.5 degrees off 26: the pads
meet the wall obliquely and it slides out between them.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np

from pg_core.action_geometry import grasp_z_at, raised_part, rim_pit
from pg_core.geometry import Geometry
from pg_core.heightmap import TOP_K, Heightmap, pixel_to_world, rotation_yaw
from pg_policy.decision.jaw_fit import JawFit
from pg_policy.decision.option import PolicyOption
from pg_policy.decision.rules.rule import BatchTest, CandidateTest, Rule, RuleContext


@dataclass(frozen=True)
class CheckVariant:
    strict: bool  # a veto (no candidate passed) asks the policy to push
    walls: bool  # candidates must also show walls where the pads touch (module docstring)
    rim_normal: bool = False  # a rim grasp must cross the wall near its normal (module docstring)


VARIANTS = {
    "jaw": CheckVariant(strict=False, walls=False),
    "jaw-strict": CheckVariant(strict=True, walls=False),
    "jaw-walls": CheckVariant(strict=True, walls=True),
    "jaw-walls-normal": CheckVariant(strict=True, walls=True, rim_normal=True),
}
NAMES = ("none", *VARIANTS)  # what the grasp_check option (`pushgrasp eval --grasp-check`) accepts
DEFAULT_VARIANT = "jaw-walls"  # the rule's variant when its entry names none
CENTRE_TOL_M = 0.01  # the learned cell may sit this far from the pad-centred line along the closing axis
WALL_WINDOW_M = 0.002  # the ends of the target's extent between the pads searched for its wall height (one cell)
WALL_TOL_M = 0.002  # the wall must stand this far above the fingertips
RIM_MAX_ANGLE_DEG = 33.75  # a rim grasp's closing line within this of the wall's normal (between 1 and 2 rotations)
WALL_BLUR_CELLS = 1.5  # the heightmap is smoothed by a Gaussian of this sigma (cells) for the wall's normal
MIN_WALL_SLOPE = 0.1  # a smoothed slope (m/m) under this gives the wall no direction (the angle test is skipped)


def wall_normal(height: np.ndarray, cell: tuple[int, int], resolution: float) -> np.ndarray | None:
    """The unit (x, y) direction in which the (H, W) heightmap `height` (m; rows along y, columns along x,
    `resolution` m per cell) rises at `cell` (row, col), smoothed by a Gaussian of WALL_BLUR_CELLS; None where the
    smoothed slope is under MIN_WALL_SLOPE (no direction to speak of)."""
    r, c = cell
    k = int(math.ceil(3 * WALL_BLUR_CELLS)) + 1
    rows, cols = np.asarray(height).shape
    r0, r1, c0, c1 = max(r - k, 0), min(r + k + 1, rows), max(c - k, 0), min(c + k + 1, cols)
    window = cv2.GaussianBlur(np.asarray(height, np.float32)[r0:r1, c0:c1], (0, 0), WALL_BLUR_CELLS,
                              borderType=cv2.BORDER_REPLICATE)
    gy, gx = np.gradient(window)  # m per cell along rows (y) and columns (x)
    g = np.array([float(gx[r - r0, c - c0]), float(gy[r - r0, c - c0])])
    norm = float(np.linalg.norm(g))
    return None if norm / resolution < MIN_WALL_SLOPE else g / norm


class JawGraspCheck(Rule):
    """Rule "grasp_check:VARIANT" (VARIANTS; default "jaw-walls"): grasp candidates must pass the jaw-footprint test
    (module docstring); `strict`: a veto (no candidate passed) asks the policy to push; `walls`: candidates also
    need walls where the pads touch."""

    name = "grasp_check"
    order = 40
    option = PolicyOption("grasp_check", "str", "jaw-footprint check of the chosen grasp: none, jaw, jaw-strict, "
                          "jaw-walls or jaw-walls-normal (strict variants push when no grasp passes; "
                          "jaw-walls-normal: jaw-walls with rim grasps near the wall's normal)", choices=NAMES,
                          rule="grasp_check", off="none")
    primitive = "grasp"
    veto_note = "no grasp passes the jaw check: push"

    def __init__(self, geometry: Geometry, top_k: int = TOP_K, centre_tol_m: float = CENTRE_TOL_M,
                 strict: bool = False, walls: bool = False, wall_window_m: float = WALL_WINDOW_M,
                 wall_tol_m: float = WALL_TOL_M, rim_normal: bool = False) -> None:
        if top_k < 1 or centre_tol_m < 0 or wall_window_m < 0:
            raise ValueError(f"grasp check needs top_k >= 1, centre_tol_m >= 0 and wall_window_m >= 0, got {top_k}, "
                             f"{centre_tol_m}, {wall_window_m}")
        self.jaw = JawFit(geometry)
        self.prims = geometry.primitives
        self.top_k, self.centre_tol, self.strict = top_k, centre_tol_m, strict
        self.walls, self.wall_window, self.wall_tol = walls, wall_window_m, wall_tol_m
        self.rim_normal = rim_normal
        self.variant = next((n for n, v in VARIANTS.items() if v == CheckVariant(strict, walls, rim_normal)),
                            f"jaw(strict={strict}, walls={walls}, rim_normal={rim_normal})")
        self.vetoes_grasp = strict  # type: ignore[misc]

    @classmethod
    def from_arg(cls, geometry: Geometry, arg: str | None) -> JawGraspCheck:
        name = DEFAULT_VARIANT if arg is None else arg
        if name not in VARIANTS:
            raise ValueError(f"unknown grasp check {name!r} (known: {', '.join(VARIANTS)})")
        v = VARIANTS[name]
        return cls(geometry, strict=v.strict, walls=v.walls, rim_normal=v.rim_normal)

    def arg(self) -> str | None:
        return self.variant

    def passes(self, hm: Heightmap, target: np.ndarray, rotation: int, row: int, col: int,
               cells_others: tuple | None = None) -> bool:
        """Whether a grasp at cell (row, col) and `rotation` passes the jaw-footprint test for the (H, W) target."""
        cells, others = cells_others or self.jaw.around(hm, target)
        t = target[cells.slice].reshape(-1)
        o = others[cells.slice].reshape(-1)
        yaw = rotation_yaw(rotation, self.jaw.rotations)
        centre = np.array(pixel_to_world(row, col, hm.bounds, hm.resolution))
        zg = grasp_z_at(hm, row, col, self.prims, yaw=yaw)  # the z action_pose executes
        u = np.array([math.cos(yaw), math.sin(yaw)])
        for low in (None, cells.h[t]):  # every target cell between the pads, then those not under the fingertips
            fit = self.jaw.grasp_fit(cells.xy[t], cells.xy[o], cells.h[o], centre, yaw, zg, t_h=low)
            if fit is not None and fit[0] >= 0 and abs(float((fit[1] - centre) @ u)) <= self.centre_tol and (
                    not self.walls or self.wall_height(cells.xy[t], cells.h[t], fit[1], yaw,
                                                       None if low is None else zg) >= zg + self.wall_tol):
                return True
        return (self.rim_grasp(hm, target, row, col, yaw, centre, zg, cells.xy[o], cells.h[o])
                or self.part_grasp(hm, target, row, col, yaw, centre, zg, cells.xy[o], cells.h[o]))

    def wall_height(self, t_xy: np.ndarray, t_h: np.ndarray, centre: np.ndarray, yaw: float,
                    z_grasp: float | None = None) -> float:
        """The lower of the target's two wall heights (m) where the pads of a grasp at `yaw` through `centre` touch:
        the highest of the (M, 2) target cells `t_xy` (heights `t_h`) between the pads and within wall_window_m of
        either end of the target's extent along the closing axis; with the fingertips' `z_grasp`, the cells under
        them left out, as `grasp_fit` leaves them out given the heights."""
        u = np.array([math.cos(yaw), math.sin(yaw)])
        v = np.array([-u[1], u[0]])
        rel = t_xy - centre
        p = self.jaw.p
        band = np.abs(rel @ v) <= self.jaw.finger_w / 2 + p.margin
        if z_grasp is not None:
            band &= t_h > z_grasp - p.obstacle_tol
        if not band.any():
            return 0.0
        s, h = rel[band] @ u, t_h[band]
        low = h[s <= s.min() + self.wall_window].max()
        high = h[s >= s.max() - self.wall_window].max()
        return float(min(low, high))

    def passes_many(self, hm: Heightmap, target: np.ndarray, rotations: np.ndarray, rows: np.ndarray,
                    cols: np.ndarray, cells_others: tuple | None = None, walls: bool | None = None,
                    clearance: bool = True) -> np.ndarray:
        """`passes` for K candidates at once: (K,) bool, candidate i being (rotations[i], rows[i], cols[i]).
        `walls` (None: the variant's) and `clearance` (False: a neighbour in a finger's sweep is allowed) relax the
        test for the forced-grasp fallback (`fallback_tests`)."""
        walls = self.walls if walls is None else walls
        cells, others = cells_others or self.jaw.around(hm, target)
        t = target[cells.slice].reshape(-1)
        o = others[cells.slice].reshape(-1)
        t_xy, t_h, o_xy, o_h = cells.xy[t], cells.h[t], cells.xy[o], cells.h[o]
        rotations, rows, cols = (np.asarray(a, dtype=np.int64).reshape(-1) for a in (rotations, rows, cols))
        yaws = rotation_yaw(rotations, self.jaw.rotations)
        cells_rc = list(zip(rows.tolist(), cols.tolist(), strict=True))
        centres = np.array([pixel_to_world(r, c, hm.bounds, hm.resolution) for r, c in cells_rc],
                           dtype=np.float64).reshape(-1, 2)
        zg = np.array([grasp_z_at(hm, r, c, self.prims, yaw=float(yw))
                       for (r, c), yw in zip(cells_rc, yaws, strict=True)], dtype=np.float64)
        u = np.stack([np.cos(yaws), np.sin(yaws)], axis=1)
        ok = np.zeros(len(zg), bool)
        for low in (None, t_h):  # every target cell between the pads, then those not under the fingertips
            clear, c2, _ = self.jaw.grasp_fit_many(t_xy, o_xy, o_h, centres, yaws, zg, t_h=low)
            fits = clear >= 0 if clearance else ~np.isnan(clear)  # NaN: the target does not fit between the pads
            fits &= ~ok & ~(np.abs(((c2 - centres)[:, None, :] @ u[:, :, None])[:, 0, 0]) > self.centre_tol)
            if walls:
                for i in np.flatnonzero(fits):
                    fits[i] = self.wall_height(t_xy, t_h, c2[i], float(yaws[i]),
                                               None if low is None else float(zg[i])) >= zg[i] + self.wall_tol
            ok |= fits
        for i in np.flatnonzero(~ok):
            args = (hm, target, int(rows[i]), int(cols[i]), float(yaws[i]), centres[i], float(zg[i]), o_xy, o_h,
                    clearance)
            ok[i] = self.rim_grasp(*args) or self.part_grasp(*args)
        return ok

    def rim_grasp(self, hm: Heightmap, target: np.ndarray, row: int, col: int, yaw: float, centre: np.ndarray,
                  z_grasp: float, o_xy: np.ndarray, o_h: np.ndarray, clearance: bool = True) -> bool:
        """Whether a grasp at target cell (row, col) closing along `yaw` is a rim grasp (module docstring): the cell
        lies in a pit of the target along the jaw line and, with `clearance`, no other object's cell ((K, 2) `o_xy`
        m, heights `o_h` m) higher than `z_grasp` - obstacle_tol lies in the open jaw's sweep around `centre`."""
        if not target[row, col]:
            return False
        pit = rim_pit(hm.height, row, col, yaw, hm.resolution, self.prims, float(hm.bounds[2, 0]), color=hm.color)
        if pit is None:
            return False
        normal = wall_normal(hm.height, pit.wall, hm.resolution) if self.rim_normal and pit.wall is not None else None
        if normal is not None and abs(float(normal @ np.array([math.cos(yaw), math.sin(yaw)]))) < math.cos(
                math.radians(RIM_MAX_ANGLE_DEG)):
            return False  # the pads would meet the wall obliquely (module docstring)
        return not clearance or self.fingers_clear(o_xy, o_h, centre, yaw, z_grasp)

    def part_grasp(self, hm: Heightmap, target: np.ndarray, row: int, col: int, yaw: float, centre: np.ndarray,
                   z_grasp: float, o_xy: np.ndarray, o_h: np.ndarray, clearance: bool = True) -> bool:
        """Whether a grasp at target cell (row, col) closing along `yaw` closes on a raised part of the target
        (module docstring; pg_core.action_geometry.raised_part) with, when `clearance`, no other object in the open
        jaw's sweep (`fingers_clear`)."""
        if not target[row, col]:
            return False
        part = raised_part(hm.height, row, col, yaw, hm.resolution, self.prims, float(hm.bounds[2, 0]),
                           color=hm.color)
        if part is None:
            return False
        return not clearance or self.fingers_clear(o_xy, o_h, centre, yaw, z_grasp)

    def fingers_clear(self, o_xy: np.ndarray, o_h: np.ndarray, centre: np.ndarray, yaw: float,
                      z_grasp: float) -> bool:
        """Whether no other object's cell ((K, 2) `o_xy` m, heights `o_h` m) higher than `z_grasp` - obstacle_tol
        lies in the open jaw's sweep around `centre` closing along `yaw`."""
        if not len(o_xy):
            return True
        p = self.jaw.p
        u = np.array([math.cos(yaw), math.sin(yaw)])
        rel = o_xy - centre
        reach = self.jaw.half_open + self.jaw.finger_t + p.margin
        sweep = (np.abs(rel @ u) <= reach) & (np.abs(rel @ np.array([-u[1], u[0]])) <= self.jaw.finger_w / 2 + p.margin)
        return not bool((sweep & (o_h > z_grasp - p.obstacle_tol)).any())

    def candidate_test(self, ctx: RuleContext) -> CandidateTest | None:
        if not ctx.visible or not ctx.target.any():
            return None
        hm, target = ctx.heightmap, ctx.target
        context = self.jaw.around(hm, target)
        return BatchTest(lambda r, row, col: self.passes_many(hm, target, r, row, col, context))

    def fallback_tests(self, ctx: RuleContext) -> list[CandidateTest]:
        """For a grasp the push budget forces when no candidate passes: first the footprint test without walls,
        then the target fitting between the pads on the pad-centred line with neighbours allowed in a finger's
        sweep (Q_g's argmax only when neither passes)."""
        if not ctx.visible or not ctx.target.any():
            return []
        hm, target = ctx.heightmap, ctx.target
        context = self.jaw.around(hm, target)
        return [BatchTest(lambda r, row, col: self.passes_many(hm, target, r, row, col, context, walls=False)),
                BatchTest(lambda r, row, col: self.passes_many(hm, target, r, row, col, context, walls=False,
                                                               clearance=False))]
