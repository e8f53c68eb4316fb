"""Heights of the grasp and push primitives from a heightmap (DESIGN.md section 4), shared by sim and policy.

Heights are TCP (fingertip centre) z in `world`, metres. Heightmap heights are metres above the workspace zmin.
"""

from __future__ import annotations

import numpy as np

from pg_core.geometry import PrimitiveSpec


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


def grasp_z(height: np.ndarray, row: int, col: int, prims: PrimitiveSpec, zmin: float = 0.0) -> float:
    """grasp_z_for_height of the height at the pixel (heightmap heights are above zmin)."""
    return grasp_z_for_height(float(height[row, col]) + zmin, prims)


def push_z(height: np.ndarray, row: int, col: int, prims: PrimitiveSpec, zmin: float = 0.0) -> float:
    """z = local max height (+- push_window_px) - push_depth, never below push_min_z."""
    return max(local_max(height, row, col, prims.push_window_px) + zmin - prims.push_depth, prims.push_min_z)
