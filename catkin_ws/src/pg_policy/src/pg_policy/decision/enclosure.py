"""Whether the target lies inside a vessel: walls standing well above it on every side, close by.

A small object inside a cup, a mug or a bowl cannot be grasped past the wall (the open jaw lands on the rim) and the
push net then pushes the vessel: the closed fingers come down on its thin rim and the contact throws the object
out (docs/RESULTS.md, "Where the household losses are"). With option enclosed_grasp (pg_policy.policies.learned,
off by default) the learned policy grasps an enclosed target at once instead (as a spent push budget does: the jaw
straddles the wall and lifts the vessel or the target).

Test on the heightmap (pg_core.heightmap: rows along y, columns along x, heights in metres above the table): from
the target's centroid, along each of `sectors` directions, the first cell beyond the target's own cells within
`reach_m` that stands `wall_m` or more above the target's highest cell is a wall; the target is enclosed when at
least `min_fraction` of the directions meet a wall.
"""

from __future__ import annotations

import math

import numpy as np

from pg_core.heightmap import Heightmap

REACH_M = 0.05  # a wall within this of the target's edge (m): a cup's or mug's inner radius is 2.5-4.5 cm
WALL_M = 0.02  # a wall stands this much above the target's top (m)
SECTORS = 16  # directions examined
MIN_FRACTION = 0.85  # share of the directions that must meet a wall


def target_enclosed(hm: Heightmap, target: np.ndarray, reach_m: float = REACH_M, wall_m: float = WALL_M,
                    sectors: int = SECTORS, min_fraction: float = MIN_FRACTION) -> bool:
    """Whether the (H, W) bool `target` lies inside walls on `hm` (module docstring). An empty mask is not enclosed.
    Raises ValueError when the mask's shape differs from the heightmap's."""
    target = np.asarray(target, dtype=bool)
    h = hm.height
    if target.shape != h.shape:
        raise ValueError(f"target mask {target.shape} and heightmap {h.shape} differ")
    if not target.any():
        return False
    rows, cols = np.nonzero(target)
    r0, c0 = float(rows.mean()), float(cols.mean())
    top = float(h[target].max())
    extent = math.hypot(rows.max() - rows.min(), cols.max() - cols.min())  # cells: a bound on the target's radius
    steps = np.arange(1, int(math.ceil(extent + reach_m / hm.resolution)) + 1)
    walled = 0
    for k in range(sectors):
        a = 2 * math.pi * k / sectors
        rr = np.rint(r0 + steps * math.sin(a)).astype(int)  # rows along +y
        cc = np.rint(c0 + steps * math.cos(a)).astype(int)
        inside = (rr >= 0) & (rr < h.shape[0]) & (cc >= 0) & (cc < h.shape[1])
        rr, cc = rr[inside], cc[inside]
        own = target[rr, cc]
        if own.all():
            continue
        beyond = int(np.argmin(own)) if own[0] else 0  # first cell past the target's own cells along the ray
        edge_steps = steps[inside][beyond:]
        near = edge_steps - edge_steps[0] <= reach_m / hm.resolution
        ray = h[rr[beyond:], cc[beyond:]][near]
        if (ray >= top + wall_m).any():
            walled += 1
    return walled >= min_fraction * sectors
