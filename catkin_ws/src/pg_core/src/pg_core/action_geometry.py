"""Heights of the grasp and push primitives from a heightmap (DESIGN.md section 4), shared by sim and policy.

Heights are TCP (fingertip centre) z in `world`, metres. Heightmap heights are metres above the workspace zmin.

The grasp height (DESIGN.md section 4, the primitive's contract) comes from the cell's height (`grasp_z_for_height`:
section 4's rule, the low-object rule below 2 cm) unless the cell lies in a pit of an object along the jaw's closing
line (`rim_pit`: the floor or inner wall of a bowl or a cup next to its wall); there the fingertips go below the
wall's top and above the floor (`grasp_z` with the rotation's yaw). On a raised part of an object wider than the
open jaw (`raised_part`: the foot ring of a bowl upside down) the fingertips pass just above the rest of the
object. With the yaw, the palm rule then keeps the palm clear of everything under its footprint (`palm_clear_z`): a
grasp never drives the palm into an object.
"""

from __future__ import annotations

import math
from functools import lru_cache
from typing import NamedTuple

import numpy as np

from pg_core.geometry import PrimitiveSpec
from pg_core.heightmap import Heightmap

PIT_TABLE_M = 0.004  # cells lower than this (m above the table) are the table, not an object's floor
PIT_CHROMA_TOL = 0.03  # cells of one object: chromaticity r, g, b / (r + g + b) within this of the centre cell's


class RimPit(NamedTuple):
    """A pit along the jaw line: the floor (m, the centre cell) and the top of the lower wall the jaw straddles (m),
    both in `world` z; `wall`: the (row, col) cell where the line meets the nearer wall (its first cell within
    half a `grasp_rim_step` of the wall's top)."""

    floor: float
    rim: float
    wall: tuple[int, int] | None = None


def local_max(height: np.ndarray, row: int, col: int, half: int) -> float:
    """Max height (m) in the (2*half+1)^2 window around (row, col), clipped to the map."""
    r0, r1 = max(row - half, 0), min(row + half + 1, height.shape[0])
    c0, c1 = max(col - half, 0), min(col + half + 1, height.shape[1])
    return float(height[r0:r1, c0:c1].max())


def grasp_z_for_height(h: float, prims: PrimitiveSpec) -> float:
    """Fingertip z (m) of a grasp where the local height is h (m above the table).

    DESIGN.md section 4: z = max(h - grasp_depth, grasp_min_z). Low objects, grasp_low_heights[0] <= h <
    grasp_low_heights[1] (thin flat things, pens lying down, small parts), take z = max(grasp_low_fraction * h,
    grasp_low_min_z) instead: below their widest part, where grasp_min_z would close the jaw above them. Taller
    objects and empty cells (h below the range: the table) keep the section 4 rule.
    """
    lo, hi = prims.grasp_low_heights
    if lo <= h < hi:
        return max(prims.grasp_low_fraction * h, prims.grasp_low_min_z)
    return max(h - prims.grasp_depth, prims.grasp_min_z)


def _side_wall(h: np.ndarray, same: np.ndarray, centre: float, reach: int, wall: int,
               step: float) -> tuple[float, int, int] | None:
    """(top (m), index of the first cell within step / 2 of it, index of the top) of the wall on one side of the
    jaw line, or None.

    h, same: heights (m) and same-object flags of the cells 1, 2, ... m from the centre along the side (beyond the
    map: not the same object). The walk follows the centre's object up to `reach` cells; a wall is its highest
    cell there standing at least `step` above the centre, thin: within `wall` cells beyond the first cell within
    step / 2 of that top, the object ends or falls `step` below the top (a bowl's rim, not a block's flat top)."""
    run = int(np.argmin(same)) if not same.all() else len(same)  # cells of the centre's object before it ends
    n = min(run, reach)
    if n == 0:
        return None
    top = float(h[:n].max())
    if top < centre + step:
        return None
    j0 = int(np.argmax(h[:n] >= top - step / 2))
    for k in range(j0 + 1, min(j0 + 1 + wall, len(h))):
        if k >= run or h[k] <= top - step:
            return top, j0, int(np.argmax(h[:n]))
    return None


@lru_cache(maxsize=64)
def _line_offsets(yaw: float, m: int) -> tuple[np.ndarray, np.ndarray]:
    """(row, col) offsets (2, m) of the cells 1 .. m along (cos yaw, sin yaw) (side +1, row 0) and against it."""
    k = np.arange(1, m + 1) * np.array([[1.0], [-1.0]])
    return (np.rint(k * math.sin(yaw)).astype(np.int64), np.rint(k * math.cos(yaw)).astype(np.int64))


def _cells(length_m: float, resolution: float) -> int:
    """The number of cells (resolution m each) that covers `length_m` m."""
    return int(math.ceil(length_m / resolution - 1e-9))


def _object_centre(height: np.ndarray, row: int, col: int, zmin: float, step: float, reach_m: float) -> float | None:
    """The `world` z (m) of cell (row, col) when a jaw-line rule with this `step` and `reach_m` is on (both > 0) and
    the cell belongs to an object (PIT_TABLE_M or more above the table); None otherwise."""
    if step <= 0 or reach_m <= 0:
        return None
    centre = float(height[row, col]) + zmin
    return None if centre < PIT_TABLE_M else centre


def _same_chroma(color: np.ndarray | None, shape: tuple[int, ...], row: int, col: int, rr: np.ndarray,
                 cc: np.ndarray) -> np.ndarray | bool:
    """Whether the cells (rr, cc) (index arrays inside the map) have the chromaticity r, g, b / (r + g + b) of cell
    (row, col) within PIT_CHROMA_TOL in the (H, W, 3) colour heightmap `color`: a bool array shaped like rr, or
    True when there is no colour (None, or not of the heightmap's `shape`)."""
    if color is None or np.shape(color)[:2] != shape[:2]:
        return True
    c0 = np.asarray(color[row, col], dtype=np.float64)
    c = np.asarray(color[rr, cc], dtype=np.float64)
    chroma = c / np.maximum(c.sum(axis=-1, keepdims=True), 1.0)
    return np.abs(chroma - c0 / max(float(c0.sum()), 1.0)).max(axis=-1) <= PIT_CHROMA_TOL


def rim_pit(height: np.ndarray, row: int, col: int, yaw: float, resolution: float, prims: PrimitiveSpec,
            zmin: float = 0.0, color: np.ndarray | None = None) -> RimPit | None:
    """The pit the cell (row, col) lies in along the jaw's closing line at `yaw`, or None (then the cell's height
    alone sets the grasp height).

    The line runs through the cell centre along (cos yaw, sin yaw) (columns along x, rows along y), `grasp_rim_reach`
    m to each side (half the open jaw). From the centre cell, which must belong to an object (at least PIT_TABLE_M
    above the table), each side is walked over cells of the same object (not the table; colour within
    PIT_CHROMA_TOL of the centre's when `color`, the (H, W, 3) colour heightmap, is given). The cell is in a pit
    when
    - one side meets a wall: its top at least `grasp_rim_step` (s) above the centre, falling s again within
      `grasp_rim_wall` beyond it (a rim, not a plateau or a block's top);
    - the other side meets a wall too, or stays off the table over the whole reach and on the same object over
      `grasp_rim_wall` (a floor between walls, not an object's flank, a handle or a gap between two objects);
    - the cell is a floor or a vessel's inner wall: a neighbour on the line lies within s / 2 of its height (not an
      edge cell between two heights), nothing lies more than s / 2 below it before a wall, and where the other
      side falls more than s / 2 below it, that side stays on the same object over the whole reach and the cell
      lies s / 2 or more below the straight line from the wall's top to the reach's end on that side (the
      inside of a vessel curving down to its floor, not the flat top of a block leaning on another).
    `rim`: the lower of the walls met; `floor`: the cell's height; `wall`: the nearer wall's cell."""
    step, reach_m = prims.grasp_rim_step, prims.grasp_rim_reach
    centre = _object_centre(height, row, col, zmin, step, reach_m)
    if centre is None:
        return None
    rows, cols = height.shape
    reach = _cells(reach_m, resolution)
    if float(height[max(row - reach, 0):row + reach + 1, max(col - reach, 0):col + reach + 1].max()) + zmin \
            < centre + step:
        return None  # nothing within reach stands a step above the cell: no wall (most cells)
    wall = max(int(math.ceil(prims.grasp_rim_wall / resolution - 1e-9)), 1)
    dr, dc = _line_offsets(round(float(yaw), 9), reach + wall)  # (2, m): side +1 then side -1
    rr, cc = row + dr, col + dc
    inside = (rr >= 0) & (rr < rows) & (cc >= 0) & (cc < cols)
    rr, cc = np.clip(rr, 0, rows - 1), np.clip(cc, 0, cols - 1)
    h = height[rr, cc].astype(np.float64) + zmin
    if min(abs(h[0, 0] - centre), abs(h[1, 0] - centre)) > step / 2:
        return None  # a crack, not a floor: neither neighbour on the line is near the cell's height (an edge cell)
    obj = inside & (h >= PIT_TABLE_M)
    same = obj & _same_chroma(color, height.shape, row, col, rr, cc)
    sides = [_side_wall(h[i], same[i], centre, reach, wall, step) for i in (0, 1)]
    if sides[0] is None and sides[1] is None:
        return None
    low = centre - step / 2
    for i, side in enumerate(sides):
        if side is not None:
            if (h[i, :side[1]] < low).any():
                return None  # the surface falls away from the cell before the wall: not a floor
            continue
        if not (obj[i, :reach].all() and same[i, :wall].all()):
            return None  # the other side reaches the table or another object: a flank, a handle, not a floor
        if (h[i, :reach] < low).any():  # it falls away: a vessel's inner wall (curving down to its floor) or a slope
            top, _, jt = sides[1 - i]  # type: ignore[misc]
            chord = h[i, reach - 1] + (top - h[i, reach - 1]) * reach / (reach + jt + 1)
            if not same[i, :reach].all() or centre > chord - step / 2:
                return None  # a leaning block's flat slope, or one ending on something else: not a vessel's inside
    i = min((i for i in (0, 1) if sides[i] is not None), key=lambda i: sides[i][1])  # type: ignore[index]
    j = sides[i][1]  # type: ignore[index]
    return RimPit(centre, min(side[0] for side in sides if side is not None), (int(rr[i, j]), int(cc[i, j])))


class RaisedPart(NamedTuple):
    """A raised part along the jaw line (`raised_part`): `top`, the part's highest cell on the line, and `fingers`,
    the highest cell the fingers pass over from their open position to the part's edges (m, `world` z)."""

    top: float
    fingers: float


def raised_part(height: np.ndarray, row: int, col: int, yaw: float, resolution: float, prims: PrimitiveSpec,
                zmin: float = 0.0, color: np.ndarray | None = None) -> RaisedPart | None:
    """The raised part of an object the jaw at `yaw` closes on at cell (row, col) with its fingertips above the rest
    of the object, or None: the foot ring of a bowl lying upside down, which is as wide as the open jaw while the
    bowl is twice as wide.

    Along the closing line through the cell (as `rim_pit`: columns along x, rows along y), each side is walked
    from the centre cell (an object's, at least PIT_TABLE_M above the table) to the part's edge: the first cell
    within `grasp_rim_reach` (half the open jaw) less a cell where the line falls by `grasp_part_step` or more within
    two cells (a wall, not the slope of a round top). Beyond each edge, out to the open pad (`grasp_rim_reach`),
    every cell must be the same object (colour within PIT_CHROMA_TOL of the centre's when `color` is given, never
    the table), and the line must stay inside the map out to the open finger's outer face (`grasp_rim_reach` +
    `finger_thickness`): the object goes on under both fingers, so that what stops them is the object itself, not a
    neighbour (the jaw check's business) or the table (an ordinary grasp). `fingers` is the highest cell from the
    edge to the outer face; the part's edge cells must stand `grasp_part_clearance` + `grasp_part_contact` or more
    above it (a round top falls gradually: the cell beyond its "edge" stands nearly as high as the one before).
    None when the rule is off (grasp_part_step 0) or any of this fails."""
    step, reach_m = prims.grasp_part_step, prims.grasp_rim_reach
    centre = _object_centre(height, row, col, zmin, step, reach_m)
    if centre is None:
        return None
    rows, cols = height.shape
    reach, outer = _cells(reach_m, resolution), _cells(reach_m + prims.finger_thickness, resolution)
    dr, dc = _line_offsets(round(float(yaw), 9), outer)  # (2, outer): side +1 then side -1
    rr, cc = row + dr, col + dc
    if not ((rr >= 0) & (rr < rows) & (cc >= 0) & (cc < cols)).all():
        return None  # a finger would land beyond the map: unseen
    h = height[rr, cc].astype(np.float64) + zmin
    same = (h >= PIT_TABLE_M) & _same_chroma(color, height.shape, row, col, rr, cc)
    line = np.concatenate([np.full((2, 2), centre), h], axis=1)  # two centre cells before each side's first
    edges, tops, fingers = [], [], []
    for side in (0, 1):
        falls = line[side, 2:reach + 1] <= np.maximum(line[side, 1:reach], line[side, :reach - 1]) - step
        if not falls.any():
            return None  # no wall within the open jaw: no part narrower than the jaw on this side
        edge = int(np.argmax(falls))  # index into h of the first cell beyond the part
        if not same[side, edge:reach].all():
            return None  # the table or another object under the open pad: not a part of a wider object
        edges.append(edge)
        tops.append(float(line[side, 1 + edge]))  # the part's last cell on this side (the centre when edge is 0)
        fingers.append(float(h[side, edge:].max()))
    part = RaisedPart(max(centre, *(float(h[i, :e].max(initial=centre)) for i, e in enumerate(edges))), max(fingers))
    if min(tops) < part.fingers + prims.grasp_part_clearance + prims.grasp_part_contact:
        return None  # the part's edges stand too little above the rest for the pads to hold them
    return part


@lru_cache(maxsize=64)
def _palm_offsets(yaw: float, half_x: float, half_y: float) -> tuple[np.ndarray, np.ndarray]:
    """(row, col) offsets, in cells, of the cells whose centres lie in the palm's footprint: |u| <= half_x along the
    closing line (cos yaw, sin yaw) (columns along x, rows along y) and |v| <= half_y across it (both in cells)."""
    r = int(math.ceil(math.hypot(half_x, half_y)))
    dr, dc = np.mgrid[-r:r + 1, -r:r + 1]
    u = dc * math.cos(yaw) + dr * math.sin(yaw)
    v = -dc * math.sin(yaw) + dr * math.cos(yaw)
    keep = (np.abs(u) <= half_x + 1e-9) & (np.abs(v) <= half_y + 1e-9)
    return dr[keep].astype(np.int64), dc[keep].astype(np.int64)


def palm_clear_z(height: np.ndarray, row: int, col: int, yaw: float, resolution: float, prims: PrimitiveSpec,
                 zmin: float = 0.0) -> float | None:
    """The lowest fingertip z (m, `world`) that keeps the palm clear: the highest cell under the palm's footprint
    (prims.palm_footprint, centred on (row, col), its x along the closing line at `yaw` rad; cells beyond the map
    left out) - prims.finger_length + prims.grasp_palm_clearance. None when the rule is off (grasp_palm_clearance
    None). A palm driven into an object presses it into the table with the arm's full force until it squeezes
    out sideways (docs/RESULTS.md, "The palm clearance")."""
    if prims.grasp_palm_clearance is None:
        return None
    half_x, half_y = (0.5 * size / resolution for size in prims.palm_footprint)
    dr, dc = _palm_offsets(round(float(yaw), 9), round(half_x, 6), round(half_y, 6))
    rr, cc = row + dr, col + dc
    inside = (rr >= 0) & (rr < height.shape[0]) & (cc >= 0) & (cc < height.shape[1])
    top = float(height[rr[inside], cc[inside]].max()) + zmin if inside.any() else zmin
    return top - prims.finger_length + prims.grasp_palm_clearance


def grasp_z(height: np.ndarray, row: int, col: int, prims: PrimitiveSpec, zmin: float = 0.0, *,
            yaw: float | None = None, color: np.ndarray | None = None, resolution: float | None = None) -> float:
    """Fingertip z (m) of a grasp at the pixel (heightmap heights are above zmin).

    Without `yaw`: grasp_z_for_height of the pixel's height. With the grasp's `yaw` (rad; `resolution`, m per cell,
    needed then; `color`: the (H, W, 3) colour heightmap, optional): where the pixel lies in a pit along the jaw
    line (`rim_pit`: a bowl's floor or inner wall next to its rim, the inside of a cup or a mug), z = max(rim -
    grasp_rim_depth, floor + grasp_rim_clearance): one finger inside the wall and one outside, the fingertips below
    the rim and above the floor; elsewhere grasp_z_for_height of the pixel's height, raised to `raised_part`'s
    fingers + grasp_part_clearance where the pixel lies on a raised part of a wider object (the foot ring of a bowl
    upside down: the fingers pass over the bowl and close on the foot). With the yaw, z is then raised
    to `palm_clear_z` where the palm would otherwise meet an object (the palm rule, when configured).
    """
    if yaw is None:
        return grasp_z_for_height(float(height[row, col]) + zmin, prims)
    if resolution is None:
        raise ValueError("grasp_z: the jaw-line rule (yaw given) needs the heightmap resolution")
    pit = rim_pit(height, row, col, yaw, resolution, prims, zmin, color)
    if pit is not None:
        z = max(pit.rim - prims.grasp_rim_depth, pit.floor + prims.grasp_rim_clearance)
    else:
        z = grasp_z_for_height(float(height[row, col]) + zmin, prims)
        part = raised_part(height, row, col, yaw, resolution, prims, zmin, color)
        if part is not None:
            z = max(z, part.fingers + prims.grasp_part_clearance)
    palm = palm_clear_z(height, row, col, yaw, resolution, prims, zmin)
    return z if palm is None else max(z, palm)


def grasp_z_at(heightmap: Heightmap, row: int, col: int, prims: PrimitiveSpec, yaw: float | None = None) -> float:
    """grasp_z on a Heightmap (its zmin, resolution and colour): the grasp height of the contract (DESIGN.md
    section 4) for a grasp at cell (row, col) closing along `yaw` (rad)."""
    return grasp_z(heightmap.height, row, col, prims, float(heightmap.bounds[2, 0]), yaw=yaw, color=heightmap.color,
                   resolution=heightmap.resolution)


def push_z(height: np.ndarray, row: int, col: int, prims: PrimitiveSpec, zmin: float = 0.0, *,
           yaw: float | None = None, resolution: float | None = None) -> float:
    """Fingertip z (m) of a push starting at the pixel: the local max height (+- push_window_px) - push_depth, never
    below push_min_z (DESIGN.md section 4). With the push's `yaw` (rad; the palm's x along it; `resolution`, m per
    cell, needed then), raised to `palm_clear_z` where the descending palm would otherwise land on an object."""
    z = max(local_max(height, row, col, prims.push_window_px) + zmin - prims.push_depth, prims.push_min_z)
    if yaw is None:
        return z
    if resolution is None:
        raise ValueError("push_z: the palm rule (yaw given) needs the heightmap resolution")
    palm = palm_clear_z(height, row, col, yaw, resolution, prims, zmin)
    return z if palm is None else max(z, palm)
