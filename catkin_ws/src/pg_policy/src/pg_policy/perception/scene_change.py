"""Did an action change the scene around the target? The heightmap comparison behind the push reward
(pg_learning.training.rewards) and the futile-push memory rule (pg_policy.decision.rules.futile_pushes).

Following the authors' code (Xu et al. 2021): "changed" counts the cells around the target (convex hull of the
target mask before the action, grown by 0.01 m) whose height fell by at least 0.01 m (changes above 0.3 m are
sensor/arm outliers and ignored) and asks for at least 50 of them. Heights are metres above the workspace zmin
(pg_core.heightmap); masks are (H, W) bool over the heightmap cells.
"""

from __future__ import annotations

import cv2
import numpy as np

from pg_core.heightmap import Heightmap
from pg_core.target_mask import dilate_mask

CHANGE_RADIUS_M = 0.01  # growth of the target hull for change detection (authors: 5 dilations of 2 mm cells)
CHANGE_DEPTH_M = 0.01  # a cell changed when its height differs by at least this (m)
CHANGE_MAX_M = 0.3  # larger height differences are outliers and ignored (m)
CHANGE_MIN_CELLS = 50  # at least this many changed cells make a change
PUSH_CHANGE_RADIUS_M = 0.05  # the push reward watches the target hull grown by this (m) for a change


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
