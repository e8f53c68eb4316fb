"""Cutting a clicked segment at its necks: objects of one colour and height that touch at a corner or a narrow
contact share one segment of the heightmap, and its outline narrows where they meet.

Contract. `cut_at_neck(segment, row, col)` takes an (H, W) bool segment (pg_policy.perception.segmentation) and the
clicked cell (row, col) in it, and returns the (H, W) bool part of it that the click names:

1. inside: the distance (cells) of every segment cell to the nearest cell outside it (OpenCV's exact L2 distance
   transform); the clicked cell climbs to the top of its hill of that distance, its peak;
2. another peak of the segment is a touching neighbour when it is object-sized (a half-width of at least
   MIN_PEAK_CELLS: a block, a cylinder, a can, not a handle, a blade, a tine or a wing tip), lies in the clicked
   cell's connected piece (the other pieces of a segment joined across a gap, pg_policy.perception.long_pieces,
   stay with the clicked part) and the two peaks are apart at the level NECK_RATIO times the lower peak: the cells
   deeper than that level fall into separate 8-connected components for the two (the outline narrows between
   them to under NECK_RATIO of the narrower one's width);
3. the segment is split among the clicked peak and those neighbours by a watershed of the distance from the
   components of step 2 (every cell follows the steepest ascent of the distance to a top, `_basins`), and the
   clicked part is returned. The watershed is written here because the libraries' gave other basins on these
   distance maps: scipy.ndimage.watershed_ift let a marker flood across a neck into a neighbour's plateau, and
   cv2.watershed floods by the difference between neighbouring cells, not by their elevation.

The segment is returned whole when no neighbour is apart from the clicked peak, when the clicked peak itself is
not object-sized (a click on a thin part), or when the clicked part would hold fewer than MIN_PART_CELLS cells.
A single object with a waist narrower than NECK_RATIO of both its ends, each object-sized (a dumbbell), is cut in
two as well: nothing in one segment tells it from two objects touching.

Units: cells of the heightmap grid (2 mm in the shipped workspace). Deterministic. Raised: ValueError when
(row, col) is not a cell of `segment`.
"""

from __future__ import annotations

import math

import cv2
import numpy as np
from scipy import ndimage

MIN_PEAK_CELLS = 6.0  # a part is object-sized when its inscribed half-width reaches this (cells; 12 mm at 2 mm)
NECK_RATIO = 0.5  # two peaks are apart where the outline between them narrows under this share of the lower one
MIN_PART_CELLS = 100  # a clicked part smaller than this (cells; 4 cm^2 at 2 mm) is not cut out


def _inside(segment: np.ndarray) -> np.ndarray:
    """(H, W) float32: each segment cell's L2 distance (cells) to the nearest cell outside it; 0 outside."""
    padded = np.pad(segment, 1).astype(np.uint8)
    return cv2.distanceTransform(padded, cv2.DIST_L2, cv2.DIST_MASK_PRECISE)[1:-1, 1:-1]


def _climb(inside: np.ndarray, row: int, col: int) -> tuple[int, int]:
    """The cell reached from (row, col) by stepping to the deepest of the 8 neighbours while it is deeper."""
    rows, cols = inside.shape
    while True:
        r0, r1, c0, c1 = max(row - 1, 0), min(row + 2, rows), max(col - 1, 0), min(col + 2, cols)
        window = inside[r0:r1, c0:c1]
        r, c = np.unravel_index(int(np.argmax(window)), window.shape)
        if window[r, c] <= inside[row, col]:
            return row, col
        row, col = r0 + int(r), c0 + int(c)


def _peaks(inside: np.ndarray, segment: np.ndarray) -> list[tuple[int, int]]:
    """Object-sized local maxima of `inside` (one cell per plateau component), deepest first."""
    top = segment & (inside >= MIN_PEAK_CELLS) & (inside >= ndimage.maximum_filter(inside, size=3))
    n, parts = cv2.connectedComponents(top.astype(np.uint8), connectivity=8)
    found = []
    for k in range(1, n):
        rr, cc = np.nonzero(parts == k)
        i = int(np.argmax(inside[rr, cc]))
        found.append((int(rr[i]), int(cc[i])))
    return sorted(found, key=lambda rc: (-float(inside[rc]), rc))


def _basins(inside: np.ndarray, segment: np.ndarray, markers: np.ndarray) -> np.ndarray:
    """(H, W) int32: the marker (> 0) each segment cell drains to, 0 outside. Every cell steps to its steepest
    ascending 8-neighbour (the rise per cell of distance) until a top; a top in a marker gives the marker, and the
    cells of a top in none take the marker of the nearest marked cell (a watershed by steepest ascent)."""
    rows, cols = inside.shape
    padded = np.pad(inside, 1, constant_values=-1.0)
    index = np.arange(rows * cols).reshape(rows, cols)
    steepest, parent = np.zeros_like(inside), index.copy()
    for dr in (-1, 0, 1):
        for dc in (-1, 0, 1):
            if dr == dc == 0:
                continue
            rise = (padded[1 + dr : 1 + dr + rows, 1 + dc : 1 + dc + cols] - inside) / math.hypot(dr, dc)
            better = rise > steepest  # the padding (-1) never rises: no step leaves the grid
            steepest = np.where(better, rise, steepest)
            parent = np.where(better, index + dr * cols + dc, parent)
    parent = parent.ravel()
    while True:  # pointer jumping: each pass halves every path to its top
        top = parent[parent]
        if np.array_equal(top, parent):
            break
        parent = top
    basins = np.where(segment, markers.ravel()[parent].reshape(rows, cols), 0).astype(np.int32)
    unmarked = segment & (basins <= 0)
    if unmarked.any():
        _, (near_r, near_c) = ndimage.distance_transform_edt(basins <= 0, return_indices=True)
        basins[unmarked] = basins[near_r[unmarked], near_c[unmarked]]
    return basins


def cut_at_neck(segment: np.ndarray, row: int, col: int) -> np.ndarray:
    """(H, W) bool: the part of `segment` the click (row, col) names (module docstring); `segment` itself when no
    object-sized neighbour meets the clicked part at a neck. Raises ValueError when (row, col) is not in it."""
    segment = np.asarray(segment, bool)
    if not (0 <= row < segment.shape[0] and 0 <= col < segment.shape[1]) or not segment[row, col]:
        raise ValueError(f"cell (row {row}, col {col}) is not in the segment")
    inside = _inside(segment)
    peak = _climb(inside, row, col)
    if inside[peak] < MIN_PEAK_CELLS:
        return segment  # a click on a thin part: nothing here is known to be one object
    _, pieces = cv2.connectedComponents(segment.astype(np.uint8), connectivity=8)
    markers = np.zeros(segment.shape, np.int32)
    n = 0
    for other in _peaks(inside, segment & (pieces == pieces[row, col])):
        level = NECK_RATIO * min(float(inside[peak]), float(inside[other]))
        _, parts = cv2.connectedComponents((inside > level).astype(np.uint8), connectivity=8)
        if parts[other] == parts[peak] or markers[other] > 0:
            continue  # joined to the clicked peak above the neck level, or within a neighbour already marked
        n += 1
        markers[(parts == parts[other]) & (markers == 0)] = n + 1
    if n == 0:
        return segment
    core_level = NECK_RATIO * float(inside[peak])
    _, parts = cv2.connectedComponents((inside > core_level).astype(np.uint8), connectivity=8)
    markers[(parts == parts[peak]) & (markers == 0)] = 1
    part = _basins(inside, segment, markers) == 1
    if part.sum() < MIN_PART_CELLS or not part[row, col]:
        return segment
    part |= segment & (pieces != pieces[row, col])
    return part
