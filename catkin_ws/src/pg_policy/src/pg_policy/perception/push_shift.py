"""Where a push carries an object: the displacement a tracker predicts for a pushed target.

Frames and units: masks are (H, W) bool over heightmap cells (pg_core.heightmap: rows along y, columns along x);
points, displacements and lengths in metres in `world`; yaw in radians (the push travels along (cos yaw, sin yaw),
as pg_sim.world.primitives and the real controller execute it).
"""

from __future__ import annotations

import math

import numpy as np

from pg_core.heightmap import Heightmap, cell_centres

PUSHER_HALF_WIDTH_M = 0.02  # half the width (m) of the closed jaw's path across the push direction (approximate)


def push_shift(mask: np.ndarray, hm: Heightmap, x: float, y: float, yaw: float,
               length: float) -> tuple[float, float]:
    """(dx, dy) m: where a push from (x, y) along yaw over `length` m carries the object of `mask` in `hm`. The
    pusher, PUSHER_HALF_WIDTH_M to each side, sweeps a corridor from PUSHER_HALF_WIDTH_M behind the start (where
    it comes down) to the end; the object's rearmost cell inside the corridor (at distance a along the push from
    its start) is met there and carried to the end: (length - max(a, 0)) along the push. (0, 0) when no cell of
    the object lies in the corridor. Rotation and sliding past are not modelled."""
    rows, cols = np.nonzero(mask)
    if rows.size == 0:
        return 0.0, 0.0
    xy = cell_centres(rows, cols, hm.bounds, hm.resolution) - np.array([x, y])
    d = np.array([math.cos(yaw), math.sin(yaw)])
    along = xy @ d
    across = xy @ np.array([-d[1], d[0]])
    hit = (np.abs(across) <= PUSHER_HALF_WIDTH_M) & (along >= -PUSHER_HALF_WIDTH_M) & (along <= length)
    if not hit.any():
        return 0.0, 0.0
    travel = max(0.0, length - max(0.0, float(along[hit].min())))
    return float(d[0] * travel), float(d[1] * travel)
