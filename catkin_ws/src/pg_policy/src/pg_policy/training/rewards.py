"""Rewards of the push and grasp nets (DESIGN.md section 7) and the heightmap measures they are built from.

- R_g = 1 if the target was grasped, else 0.
- R_p = +0.5 if the push raised the target's masked max Q_g by more than ``Q_GAIN`` (0.1), changed the scene around
  the target and (as the paper authors' code also requires) lowered the occupancy ratio around the target by more
  than ``OCC_DROP`` (0.1); -0.5 if nothing changed around the target; 0 otherwise.

Following the authors' code (Xu et al. 2021, on which the paper's code builds): "changed" counts the cells around
the target (convex hull of the target mask before the push, grown by 0.01 m) whose height fell by at least 0.01 m
(changes above 0.3 m are sensor/arm outliers and ignored) and asks for at least 50 of them; the occupancy ratio is
the fraction of a 0.02 m ring around the target whose height is at least 0.02 m. Their code also gives -0.5 when the
occupancy did not drop; that stricter variant is ``push_reward(..., penalize_no_occupancy_drop=True)``.
Heights are metres above the workspace zmin (pg_core.heightmap); masks are (H, W) bool over the heightmap cells.
"""

from __future__ import annotations

import cv2
import numpy as np

from pg_core.heightmap import Heightmap
from pg_core.target_mask import dilate_mask

PUSH_GOOD = 0.5
PUSH_BAD = -0.5
Q_GAIN = 0.1  # Q_g(after) - Q_g(before) must exceed this for a good push
OCC_DROP = 0.1  # occupancy(before) - occupancy(after) must exceed this when an occupancy drop is required
CHANGE_RADIUS_M = 0.01  # growth of the target hull for change detection (authors: 5 dilations of 2 mm cells)
CHANGE_DEPTH_M = 0.01  # a cell changed when its height differs by at least this (m)
CHANGE_MAX_M = 0.3  # larger height differences are outliers and ignored (m)
CHANGE_MIN_CELLS = 50  # at least this many changed cells make a change
PUSH_CHANGE_RADIUS_M = 0.05  # the push reward watches the target hull grown by this (m) for a change
OCC_RADIUS_M = 0.02  # width of the ring around the target for the occupancy ratio (authors: 10 dilations)
OCC_HEIGHT_M = 0.02  # a ring cell is occupied when its height is at least this (m)


def grasp_reward(target_grasped: bool) -> float:
    """1.0 if the target was grasped (and held after the lift), else 0.0."""
    return 1.0 if target_grasped else 0.0


def _check_pair(before: Heightmap, after: Heightmap, mask: np.ndarray) -> np.ndarray:
    mask = np.asarray(mask, dtype=bool)
    if before.height.shape != after.height.shape or mask.shape != before.height.shape:
        raise ValueError(f"heightmaps {before.height.shape}, {after.height.shape} and mask {mask.shape} differ")
    return mask


def convex_hull_mask(mask: np.ndarray) -> np.ndarray:
    """(H, W) bool: the filled convex hull of the True cells of `mask` (empty stays empty)."""
    mask = np.asarray(mask, dtype=bool)
    pts = np.argwhere(mask)
    if len(pts) == 0:
        return mask.copy()
    hull = cv2.convexHull(pts[:, ::-1].astype(np.int32))  # (x = col, y = row) points
    out = np.zeros(mask.shape, np.uint8)
    cv2.fillConvexPoly(out, hull, 1)
    return out.astype(bool) | mask


def change_region(target: np.ndarray, resolution: float, radius_m: float = CHANGE_RADIUS_M,
                  hull: bool = True) -> np.ndarray:
    """(H, W) bool: the cells watched for a change: the target mask (or its convex hull) grown by `radius_m` m."""
    base = convex_hull_mask(target) if hull else np.asarray(target, dtype=bool)
    return dilate_mask(base, resolution, radius_m)


def changed_cells(before: Heightmap, after: Heightmap, target_before: np.ndarray, radius_m: float = CHANGE_RADIUS_M,
                  depth_thresh: float = CHANGE_DEPTH_M, max_change: float = CHANGE_MAX_M, decrease_only: bool = True,
                  hull: bool = True) -> int:
    """Number of cells of the change region whose height changed by depth_thresh..max_change metres.

    Only cells valid in both heightmaps count. decrease_only: count only cells that got lower (the authors' rule:
    an object moved away from the target); False counts any change of height. Raises ValueError on shape mismatch.
    """
    target_before = _check_pair(before, after, target_before)
    region = change_region(target_before, before.resolution, radius_m, hull) & before.valid & after.valid
    diff = before.height.astype(np.float64) - after.height.astype(np.float64)
    if not decrease_only:
        diff = np.abs(diff)
    return int(np.count_nonzero(region & (diff >= depth_thresh) & (diff <= max_change)))


def scene_changed(before: Heightmap, after: Heightmap, target_before: np.ndarray, radius_m: float = CHANGE_RADIUS_M,
                  depth_thresh: float = CHANGE_DEPTH_M, min_cells: int = CHANGE_MIN_CELLS, decrease_only: bool = True,
                  hull: bool = True) -> bool:
    """Did the action change the scene around the target?

    before, after: heightmaps before and after the action; target_before: (H, W) bool target mask before it;
    radius_m: growth (m) of the target's convex hull (`hull`=True) or mask into the watched region;
    depth_thresh: smallest height change (m) that counts; min_cells: changed cells needed (at 0.002 m/cell 50 cells
    = 2 cm^2); decrease_only: see :func:`changed_cells`. Raises ValueError on shape mismatch.
    """
    return changed_cells(before, after, target_before, radius_m, depth_thresh, decrease_only=decrease_only,
                         hull=hull) >= min_cells


def occupancy_ratio(heightmap: Heightmap, target_mask: np.ndarray, radius_m: float = OCC_RADIUS_M,
                    height_thresh: float = OCC_HEIGHT_M, max_height: float = CHANGE_MAX_M) -> float:
    """Fraction (0..1) of the ring around the target occupied by other objects.

    The ring: cells within `radius_m` metres of the (H, W) bool target mask, the mask itself excluded. A ring cell
    is occupied when it is valid and its height lies in [height_thresh, max_height] metres. Returns 0.0 for an
    empty ring (empty target mask). Raises ValueError on shape mismatch.
    """
    mask = np.asarray(target_mask, dtype=bool)
    if mask.shape != heightmap.height.shape:
        raise ValueError(f"target mask {mask.shape} does not match the heightmap {heightmap.height.shape}")
    ring = dilate_mask(mask, heightmap.resolution, radius_m) & ~mask
    n = int(np.count_nonzero(ring))
    if n == 0:
        return 0.0
    h = heightmap.height
    occupied = ring & heightmap.valid & (h >= height_thresh) & (h <= max_height)
    return float(np.count_nonzero(occupied)) / n


def push_reward(qg_before_max: float, qg_after_max: float, changed: bool, occ_before: float, occ_after: float,
                require_occupancy_drop: bool = True, q_gain: float = Q_GAIN, occ_drop: float = OCC_DROP,
                penalize_no_occupancy_drop: bool = False) -> float:
    """R_p of one push: +0.5, -0.5 or 0.

    qg_before_max, qg_after_max: masked max of Q_g over the target before / after the push (-inf for an invisible
    target counts as no gain); changed: :func:`scene_changed`; occ_before, occ_after: :func:`occupancy_ratio` before
    / after. +0.5 when qg_after - qg_before > q_gain and changed (and, with require_occupancy_drop,
    occ_before - occ_after > occ_drop); -0.5 when not changed (and, with penalize_no_occupancy_drop, also when the
    occupancy did not drop by more than occ_drop, as in the authors' code); 0.0 otherwise.
    """
    occ_dropped = (occ_before - occ_after) > occ_drop
    gain = qg_after_max - qg_before_max
    gained = bool(gain > q_gain)  # NaN (both -inf) is no gain; -inf before and finite after is a gain
    if changed and gained and (occ_dropped or not require_occupancy_drop):
        return PUSH_GOOD
    if not changed or (penalize_no_occupancy_drop and not occ_dropped):
        return PUSH_BAD
    return 0.0
