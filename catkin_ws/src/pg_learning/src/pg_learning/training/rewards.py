"""Rewards of the push and grasp nets (DESIGN.md section 7) and the heightmap measures they are built from.

- R_g = 1 if the target was grasped, else 0.
- R_p = +0.5 if the push raised the target's masked max Q_g by more than ``Q_GAIN`` (0.1), changed the scene around
  the target and (as the paper authors' code also requires) lowered the occupancy ratio around the target by more
  than ``OCC_DROP`` (0.1); -0.5 if nothing changed around the target; 0 otherwise.

Following the authors' code (Xu et al. 2021, on which the paper's code builds): "changed" is
pg_policy.perception.scene_change.scene_changed (with PUSH_CHANGE_RADIUS_M in the trainer); the occupancy ratio is
the fraction of a 0.02 m ring around the target whose height is at least 0.02 m. Their code also gives -0.5 when the
occupancy did not drop; that stricter variant is ``push_reward(..., penalize_no_occupancy_drop=True)``.
Heights are metres above the workspace zmin (pg_core.heightmap); masks are (H, W) bool over the heightmap cells.
"""

from __future__ import annotations

import numpy as np

from pg_core.heightmap import Heightmap
from pg_core.target_mask import dilate_mask
from pg_policy.perception.scene_change import CHANGE_MAX_M

PUSH_GOOD = 0.5
PUSH_BAD = -0.5
Q_GAIN = 0.1  # Q_g(after) - Q_g(before) must exceed this for a good push
OCC_DROP = 0.1  # occupancy(before) - occupancy(after) must exceed this when an occupancy drop is required
OCC_RADIUS_M = 0.02  # width of the ring around the target for the occupancy ratio (authors: 10 dilations)
OCC_HEIGHT_M = 0.02  # a ring cell is occupied when its height is at least this (m)


def grasp_reward(target_grasped: bool) -> float:
    """1.0 if the target was grasped (and held after the lift), else 0.0."""
    return 1.0 if target_grasped else 0.0


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

    qg_before_max, qg_after_max: masked max of Q_g over the target before / after the push (-inf for an invisible target
    counts as no gain); changed: pg_policy.perception.scene_change.scene_changed; occ_before, occ_after:
    :func:`occupancy_ratio` before / after. +0.5 when qg_after - qg_before > q_gain and changed (and, with
    require_occupancy_drop, occ_before - occ_after > occ_drop); -0.5 when not changed (and, with
    penalize_no_occupancy_drop, also when the occupancy did not drop by more than occ_drop, as in the authors'
    code); 0.0 otherwise.
    """
    occ_dropped = (occ_before - occ_after) > occ_drop
    gain = qg_after_max - qg_before_max
    gained = bool(gain > q_gain)  # NaN (both -inf) is no gain; -inf before and finite after is a gain
    if changed and gained and (occ_dropped or not require_occupancy_drop):
        return PUSH_GOOD
    if not changed or (penalize_no_occupancy_drop and not occ_dropped):
        return PUSH_BAD
    return 0.0
