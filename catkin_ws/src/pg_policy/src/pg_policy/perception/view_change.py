"""What changed between two heightmaps of the same grid, cell by cell: the comparison the target tracker
(pg_policy.perception.target_tracker) makes between the view the target was last found in and the new one.

A cell is unchanged when its height stays within STILL_DEPTH_M and its colour (CIE Lab, lightness weighted by
segmentation.LIGHTNESS_WEIGHT) within STILL_COLOUR. Heights are metres above the workspace zmin (pg_core.heightmap);
every mask is (H, W) bool over the heightmap cells.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from pg_core.heightmap import Heightmap
from pg_policy.perception.segmentation import LIGHTNESS_WEIGHT, object_cells

STILL_DEPTH_M = 0.003  # a cell is unchanged between two views when its height differs by less than this (m) ...
STILL_COLOUR = 10.0  # ... and its Lab colour (lightness weighted) by less than this


class ViewChange(NamedTuple):
    """still: the object cells of the new view whose height and colour stayed; arrived: the cells that rose by
    STILL_DEPTH_M or more (something moved in); uncovered: the object cells that fell by as much, or were unseen
    before (what lay on them moved away); recoloured: the cells whose colour changed by STILL_COLOUR or more."""

    still: np.ndarray
    arrived: np.ndarray
    uncovered: np.ndarray
    recoloured: np.ndarray


def view_change(before: Heightmap, before_lab: np.ndarray, after: Heightmap, after_lab: np.ndarray) -> ViewChange:
    """The cells that changed from `before` to `after` (their (H, W, 3) float32 Lab images beside them)."""
    both = np.asarray(before.valid, bool) & np.asarray(after.valid, bool)
    rise = np.asarray(after.height, np.float32) - np.asarray(before.height, np.float32)
    weights = np.array([LIGHTNESS_WEIGHT, 1.0, 1.0], np.float32)
    colour = np.linalg.norm((after_lab - before_lab) * weights, axis=-1)
    recoloured = both & (colour >= STILL_COLOUR)
    objects = object_cells(after)
    still = both & (np.abs(rise) < STILL_DEPTH_M) & ~recoloured & objects
    bare = (both & (rise <= -STILL_DEPTH_M)) | (np.asarray(after.valid, bool) & ~np.asarray(before.valid, bool))
    return ViewChange(still, both & (rise >= STILL_DEPTH_M), bare & objects, recoloured)
