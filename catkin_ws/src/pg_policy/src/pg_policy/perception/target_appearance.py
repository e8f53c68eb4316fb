"""What a target looks like in one heightmap, for pg_policy.perception.target_tracker: its Appearance (colour,
area, heights, shape, place, whether another object covers part of it), the CIE94 colour difference that compares
two appearances, the terms that score a segment against the target's record (`match_terms`), and masks moved by
whole cells.

Frames and units: masks are (H, W) bool over the heightmap cells (pg_core.heightmap: rows along y, columns along x);
heights in metres above the table, areas in cells, centroids (row, col) in cells; Lab colours as
pg_policy.perception.segmentation.lab_image makes them. `describe` needs a non-empty mask.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np

from pg_core.heightmap import Heightmap
from pg_policy.perception.segmentation import DEPTH_EDGE_M, LIGHTNESS_WEIGHT, lab_image

TOP_QUANTILE = 0.9  # the target's "top" height is this quantile of its cells' heights
COVERED_BORDER = 0.25  # a target is partly covered when this fraction of its border stands higher than its top
COLOUR_SCALE = 12.0  # CIE94 difference (lightness weighted) at which the colour term falls to 1/e
HEIGHT_SCALE_M = 0.01  # median height difference (m) at which the height term falls to 1/e
HU1_SCALE = 0.03  # first Hu moment difference (a square 0.167, a 2:1 rectangle 0.208) weighing 1/e
RATIO_SCALE = 0.3  # minor/major axis ratio difference (a square 1, a 2:1 rectangle 0.5) weighing 1/e
EXTENT_SLACK = 0.05  # extent differences up to this are the grid's (a square turned on it: 0.90-1.0) ...
EXTENT_SCALE = 0.1  # ... and beyond it this much weighs 1/e (a disc 0.76 against a square 0.9-1: 0.15-0.35)
DISTANCE_SCALE_M = 0.05  # centroid distance (m) from the predicted place at which the nearness term falls to 1/e
UNKNOWN_TERM = 0.5  # the area and shape terms of a segment larger than a partly covered target's record


@dataclass(frozen=True, eq=False)
class Appearance:
    """What a mask shows: median Lab (3,), area (cells), median and top height (m), first Hu moment, minor/major
    axis ratio in [0, 1], centroid (row, col) in cells, extent (its area over that of its smallest enclosing
    rectangle, `extent`: a square 0.9-1, a disc 0.76, a triangle 0.5) and (the tracked target's record only) whether
    it is partly covered (`partly_covered`)."""

    lab: np.ndarray
    area: int
    height: float
    top: float
    hu1: float
    ratio: float
    centroid: tuple[float, float]
    partial: bool = False
    extent: float = 1.0


def describe(hm: Heightmap, mask: np.ndarray, lab: np.ndarray | None = None) -> Appearance:
    """The Appearance of the (non-empty, (H, W) bool) `mask` in `hm`; `lab`: hm's Lab image when already made."""
    lab = lab_image(hm.color) if lab is None else lab
    cells = mask & np.asarray(hm.valid, dtype=bool)
    cells = cells if cells.any() else mask
    heights = np.asarray(hm.height, dtype=np.float64)[cells]
    m = cv2.moments(mask.astype(np.uint8), binaryImage=True)
    cov = np.array([[m["mu20"], m["mu11"]], [m["mu11"], m["mu02"]]]) / m["m00"]
    low, high = np.linalg.eigvalsh(cov)  # variances along the minor and major axes (cells^2)
    ratio = math.sqrt(max(low, 0.0) / high) if high > 0 else 1.0
    return Appearance(np.median(lab[cells], axis=0), int(mask.sum()), float(np.median(heights)),
                      float(np.quantile(heights, TOP_QUANTILE)), float(cv2.HuMoments(m)[0, 0]), ratio,
                      (m["m01"] / m["m00"], m["m10"] / m["m00"]), extent=extent(mask))


def extent(mask: np.ndarray) -> float:
    """The (H, W) bool non-empty `mask`'s cell count over the area (cells) of its smallest enclosing rotated
    rectangle (cv2.minAreaRect of the cell centres, each side grown by one cell), at most 1: rotation invariant up
    to the grid (a square reads 0.90-1.0 at any angle)."""
    pts = np.column_stack(np.nonzero(mask)).astype(np.float32)
    (_, _), (w, h), _ = cv2.minAreaRect(pts)
    return min(1.0, float(mask.sum()) / ((w + 1.0) * (h + 1.0)))


def partly_covered(hm: Heightmap, mask: np.ndarray) -> bool:
    """Whether another object lies over part of the (H, W) bool `mask`: at least COVERED_BORDER of the valid cells
    bordering it (within 2 cells) stand DEPTH_EDGE_M or more above its top (TOP_QUANTILE) height."""
    ring = (cv2.dilate(mask.astype(np.uint8), np.ones((5, 5), np.uint8)) > 0) & ~mask & np.asarray(hm.valid, bool)
    if not ring.any():
        return False
    height = np.asarray(hm.height, np.float64)
    higher = height[ring] >= np.quantile(height[mask], TOP_QUANTILE) + DEPTH_EDGE_M
    return bool(higher.mean() >= COVERED_BORDER)


def delta_e94(reference: np.ndarray, sample: np.ndarray, k_l: float = 1.0 / LIGHTNESS_WEIGHT) -> float:
    """CIE94 colour difference (graphic-arts weights) of two Lab colours (3,), `reference` the first view's:
    sqrt((dL / k_l)^2 + (dC / (1 + 0.045 C_ref))^2 + (dH / (1 + 0.015 C_ref))^2), C chroma, dH the hue difference
    as an arc. Written out (five lines) because neither OpenCV nor the project's other dependencies provide it."""
    (l1, a1, b1), (l2, a2, b2) = (float(v) for v in reference), (float(v) for v in sample)
    c1, c2 = math.hypot(a1, b1), math.hypot(a2, b2)
    dh2 = max((a1 - a2) ** 2 + (b1 - b2) ** 2 - (c1 - c2) ** 2, 0.0)
    return math.sqrt(((l1 - l2) / k_l) ** 2 + ((c1 - c2) / (1.0 + 0.045 * c1)) ** 2 + dh2 / (1.0 + 0.015 * c1) ** 2)


def shifted(mask: np.ndarray, rows: int, cols: int) -> np.ndarray:
    """(H, W) bool: `mask` moved by whole cells (rows down, cols right); cells moved off the grid are dropped."""
    out = np.zeros_like(mask)
    h, w = mask.shape
    if abs(rows) >= h or abs(cols) >= w:
        return out
    src = mask[max(-rows, 0) : h - max(rows, 0), max(-cols, 0) : w - max(cols, 0)]
    out[max(rows, 0) : h - max(-rows, 0), max(cols, 0) : w - max(-cols, 0)] = src
    return out


def match_terms(ref: Appearance, seen: Appearance, seg: np.ndarray, predicted: np.ndarray,
                expected: tuple[float, float], resolution: float) -> tuple[float, float, float, float]:
    """(colour, form, overlap, nearness), each in [0, 1], of a segment against the target's record `ref`: `seen`
    is the (H, W) bool segment `seg`'s Appearance, `predicted` the (H, W) bool mask where the target is expected,
    `expected` its centroid (row, col) in cells, `resolution` m per cell. colour: exp(-delta_e94 / COLOUR_SCALE);
    form: the mean of the height, area-ratio and shape terms (pg_policy.perception.target_tracker's module
    docstring), the area and shape terms UNKNOWN_TERM for a segment larger than a partly covered record; overlap:
    the IoU of `seg` with `predicted`; nearness: exp(-d / DISTANCE_SCALE_M), d the centroid distance in m."""
    colour = math.exp(-delta_e94(ref.lab, seen.lab) / COLOUR_SCALE)
    height = math.exp(-(abs(seen.height - ref.height) + abs(seen.top - ref.top)) / 2 / HEIGHT_SCALE_M)
    if ref.partial and seen.area > ref.area:  # more of it may be in view now: its area and shape say nothing
        area = shape = UNKNOWN_TERM
    else:
        area = min(seen.area, ref.area) / max(seen.area, ref.area)
        shape = math.exp(-abs(seen.hu1 - ref.hu1) / HU1_SCALE - abs(seen.ratio - ref.ratio) / RATIO_SCALE
                         - max(abs(seen.extent - ref.extent) - EXTENT_SLACK, 0.0) / EXTENT_SCALE)
    union = int((seg | predicted).sum())
    overlap = int((seg & predicted).sum()) / union if union else 0.0
    dist_m = math.hypot(seen.centroid[0] - expected[0], seen.centroid[1] - expected[1]) * resolution
    near = math.exp(-dist_m / DISTANCE_SCALE_M)
    return colour, (height + area + shape) / 3.0, overlap, near
