"""The pieces of one long object that a top-down heightmap shows apart, joined: step 6 of
pg_policy.perception.segmentation.

A rod with another object lying across it is seen on both sides of that object, and a bar that bends over
something thin is split where it bends (a depth edge). A label at least as elongated as JOIN_ELONGATION (the minor /
major standard deviation of its cells) takes in a label of its colour (median weighted Lab within the
segmentation's colour edge) and height (medians within JOIN_HEIGHT_M) that continues it along its major axis: the
other's cells lie, at the median, within its half-width plus JOIN_OFFSET_CELLS of the axis and, at the 95th
percentile, within twice that; a label less round than JOIN_ALIGNED lies within JOIN_ANGLE_DEG of the axis. Either
the two touch end to end (both elongated, their extents along the axis overlapping by at most the half-width), or a
gap of at most JOIN_GAP_M lies between them whose band of the piece's width is at least JOIN_COVERED unseen cells or
other objects' cells no lower than the pieces. Joined labels need not be connected.

Frames and units: (H, W) grids over the heightmap cells (rows along y, columns along x); heights in metres.
Deterministic: the same labels and heightmap give the same joins.
"""

from __future__ import annotations

import math

import cv2
import numpy as np
from scipy import ndimage

JOIN_ELONGATION = 0.4  # a label this elongated (minor / major spread) or more is part of a long object
JOIN_ALIGNED = 0.6  # ... another label less round than this must lie along it (within JOIN_ANGLE_DEG)
JOIN_ANGLE_DEG = 15.0  # ... the largest angle between the major axes of two pieces of one long object
JOIN_OFFSET_CELLS = 2.0  # ... the other piece lies within the half-width plus this many cells of the axis
JOIN_HEIGHT_M = 0.01  # ... the pieces' median heights differ by at most this (m)
JOIN_GAP_M = 0.10  # ... an object lying across a long one hides at most this much of it (m along the axis)
JOIN_COVERED = 0.8  # ... and covers at least this fraction of the gap's band (unseen cells count as covered)


def _axes(rows: np.ndarray, cols: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
    """(centre, major, minor, roundness) of cells: centre (x = col, y = row), unit axes in (col, row) and the
    ratio of the minor to the major standard deviation (1 round, 0 a line)."""
    pts = np.stack([cols, rows], axis=1).astype(float)
    centre = pts.mean(axis=0)
    spread, axes = np.linalg.eigh(np.cov(pts.T)) if len(pts) > 2 else (np.ones(2), np.eye(2))
    return centre, axes[:, 1], axes[:, 0], float(np.sqrt(max(spread[0], 0.0) / max(spread[1], 1e-9)))


def join_pieces(labels: np.ndarray, height: np.ndarray, valid: np.ndarray, lab: np.ndarray, resolution: float,
                colour_edge: float) -> np.ndarray:
    """(H, W) int32 labels with the pieces of one long object joined under one label (module docstring).

    labels: (H, W) int32, 0 off objects, 1..N; height: (H, W) float32 m; valid: (H, W) bool; lab: (H, W, 3) float32
    weighted Lab (lightness scaled as the segmentation's colour edges); resolution: m per cell; colour_edge: the
    largest weighted Lab distance between the pieces' median colours."""
    count = int(labels.max())
    if count < 2:
        return labels
    cells = ndimage.find_objects(labels)
    pieces = {}
    for k in range(1, count + 1):
        box = cells[k - 1]
        rows, cols = np.nonzero(labels[box] == k)
        rows, cols = rows + box[0].start, cols + box[1].start
        centre, major, minor, roundness = _axes(rows, cols)
        pieces[k] = (rows, cols, centre, major, minor, roundness, np.median(lab[rows, cols], axis=0),
                     float(np.median(height[rows, cols])))
    parent = list(range(count + 1))

    def root(k: int) -> int:
        while parent[k] != k:
            k = parent[k]
        return k

    gap_cells = JOIN_GAP_M / resolution
    aligned = math.cos(math.radians(JOIN_ANGLE_DEG))
    grow = np.ones((3, 3), np.uint8)
    for a, (rows, cols, centre, major, minor, roundness, colour, level) in pieces.items():
        if roundness > JOIN_ELONGATION:
            continue
        u = (cols - centre[0]) * major[0] + (rows - centre[1]) * major[1]
        v = (cols - centre[0]) * minor[0] + (rows - centre[1]) * minor[1]
        half = float(max(-np.percentile(v, 5), np.percentile(v, 95)))
        for b, (rows_b, cols_b, _, major_b, _, roundness_b, colour_b, level_b) in pieces.items():
            if root(a) == root(b) or float(np.linalg.norm(colour - colour_b)) >= colour_edge \
                    or abs(level - level_b) > JOIN_HEIGHT_M:
                continue
            if roundness_b < JOIN_ALIGNED and abs(float(major @ major_b)) < aligned:
                continue
            u_b = (cols_b - centre[0]) * major[0] + (rows_b - centre[1]) * major[1]
            v_b = np.abs((cols_b - centre[0]) * minor[0] + (rows_b - centre[1]) * minor[1])
            if np.median(v_b) > half + JOIN_OFFSET_CELLS or np.percentile(v_b, 95) > 2 * (half + JOIN_OFFSET_CELLS):
                continue
            lo, hi = (u.max(), u_b.min()) if u_b.min() > u.max() else (u_b.max(), u.min())
            if hi - lo <= 1.0:  # next to each other along the axis: end to end, touching, both long
                box = tuple(slice(max(sl.start - 1, 0), sl.stop + 1) for sl in cells[a - 1])
                touching = (cv2.dilate((labels[box] == a).astype(np.uint8), grow) > 0) & (labels[box] == b)
                joins = (-(hi - lo) <= max(3.0, half) and roundness_b <= JOIN_ELONGATION
                         and bool(touching.any()) and abs(float(major @ major_b)) >= aligned)
            else:
                joins = hi - lo <= gap_cells and _covered(labels, height, valid, centre, major, minor, (lo, hi),
                                                         half, (a, b), max(level, level_b))
            if joins:
                parent[root(b)] = root(a)
    return np.array([root(k) for k in range(count + 1)], np.int32)[labels]


def _covered(labels: np.ndarray, height: np.ndarray, valid: np.ndarray, centre: np.ndarray, major: np.ndarray,
             minor: np.ndarray, span: tuple[float, float], half: float, pair: tuple[int, int], level: float) -> bool:
    """Whether the band between two pieces (along `major` from span[0] to span[1] cells, |offset| <= `half`) is
    at least JOIN_COVERED unseen cells or cells of other labels no lower than `level` (m)."""
    ends = [centre + t * major + s * minor for t in span for s in (-half, half)]
    c0, r0 = np.floor(np.min(ends, axis=0)).astype(int)
    c1, r1 = np.ceil(np.max(ends, axis=0)).astype(int) + 1
    r0, c0 = max(r0, 0), max(c0, 0)
    rows, cols = np.mgrid[r0:r1, c0:c1]
    u = (cols - centre[0]) * major[0] + (rows - centre[1]) * major[1]
    v = (cols - centre[0]) * minor[0] + (rows - centre[1]) * minor[1]
    band = (u > span[0] + 0.5) & (u < span[1] - 0.5) & (np.abs(v) <= half)
    if not band.any():
        return False
    box = (slice(r0, r1), slice(c0, c1))
    window = labels[box]
    cover = ~valid[box] | ((window > 0) & (height[box] >= level))
    cover &= (window != pair[0]) & (window != pair[1])
    return float(cover[band[: window.shape[0], : window.shape[1]]].mean()) >= JOIN_COVERED
