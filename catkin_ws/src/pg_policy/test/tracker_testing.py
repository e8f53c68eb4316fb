"""Heightmaps of flat blocks for the target tracker's tests (shared by test_target_tracker*.py)."""

from __future__ import annotations

import numpy as np

from pg_core.geometry import load
from pg_core.heightmap import Heightmap

GEO = load()
RED, BLUE = (200, 40, 40), (40, 60, 200)


def blocks(*placed: tuple[int, int, tuple[int, int, int]]) -> Heightmap:
    """A heightmap of 4 x 4 cm blocks, 3 cm tall: (row, col, RGB) of each block's first cell."""
    height = np.zeros((224, 224), np.float32)
    colour = np.full((224, 224, 3), 200, np.uint8)
    for row, col, rgb in placed:
        height[row : row + 20, col : col + 20], colour[row : row + 20, col : col + 20] = 0.03, rgb
    return Heightmap(colour, height, np.ones((224, 224), bool), GEO.heightmap.resolution, GEO.workspace.bounds)


def iou(a: np.ndarray, b: np.ndarray) -> float:
    return float((a & b).sum() / max((a | b).sum(), 1))
