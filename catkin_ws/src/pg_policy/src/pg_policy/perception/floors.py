"""A vessel's raised floor joins its wall: one object, not a disc inside a ring.

Segmentation (pg_policy.perception.segmentation) splits objects at height bends; a concave object whose floor stands
above the table (a bowl's or a cup's base, a toothed dish, a tray) bends where the floor meets the inner wall, so the
floor becomes a label of its own that the wall's label encloses. A click at such an object's middle then names the
floor alone. `join_floors` gives each such floor to its wall: a label whose outer border (the cells around it once
its own holes are filled, up to GAP_CELLS away: a groove or an unseen slit may part floor and wall) lies, for at
least ENCLOSED_SHARE of its labelled cells, on one other label, and for at most TABLE_SHARE on none; that lies in a
hole of that label (a ring around it, not objects beside it); whose median colour is within `colour_edge` of that
label's (chroma weighted Lab, as the segmentation measures it); and which lies at least FLOOR_STEP_M under that
label (medians of their heights). An object lying in a vessel of another colour, or standing as high as the
vessel's wall, is left alone; one of the vessel's colour, lower than its wall, is taken for its floor.

Frames and units: labels (H, W) int32 (0: table or unseen), heights (H, W) float32 m above the table, colours
(H, W, 3) float32 Lab weighted as the caller compares colours. Deterministic.
"""

from __future__ import annotations

import cv2
import numpy as np
from scipy import ndimage

ENCLOSED_SHARE = 0.9  # this share of a label's outer border on one other label: that label encloses it
TABLE_SHARE = 0.5  # ... with at most this share of the border on no label (a groove, an unseen slit)
GAP_CELLS = 3  # the border: the cells within this many cells of the label
FLOOR_STEP_M = 0.005  # a floor lies at least this much (m) under its wall (medians)
MIN_FLOOR_CELLS = 20  # smaller labels are not joined (speckle; the segmentation's MIN_OBJECT_CELLS)


def join_floors(labels: np.ndarray, height: np.ndarray, weighted_lab: np.ndarray, colour_edge: float) -> np.ndarray:
    """(H, W) int32: `labels` with every enclosed floor (module docstring) relabelled as the label around it;
    labels are not renumbered."""
    out = labels.copy()
    for label in np.unique(labels[labels > 0]):
        part = out == label
        if int(part.sum()) < MIN_FLOOR_CELLS:
            continue
        rows, cols = np.nonzero(part)
        r0, r1 = rows.min() - GAP_CELLS, rows.max() + GAP_CELLS + 1
        c0, c1 = cols.min() - GAP_CELLS, cols.max() + GAP_CELLS + 1
        if r0 < 0 or c0 < 0 or r1 > out.shape[0] or c1 > out.shape[1]:
            continue  # at the heightmap's edge: not seen enclosed
        window = out[r0:r1, c0:c1]
        filled = ndimage.binary_fill_holes(part[r0:r1, c0:c1])
        grow = np.ones((2 * GAP_CELLS + 1,) * 2, np.uint8)
        ring = cv2.dilate(filled.astype(np.uint8), grow).astype(bool) & ~filled
        around = window[ring]
        labelled = around[around > 0]
        if labelled.size == 0 or labelled.size < (1 - TABLE_SHARE) * around.size:
            continue
        owners, counts = np.unique(labelled, return_counts=True)
        wall = int(owners[np.argmax(counts)])
        if wall == label or counts.max() < ENCLOSED_SHARE * labelled.size:
            continue
        wall_cells = out == wall
        if not ndimage.binary_fill_holes(wall_cells)[part].all():
            continue  # not in a hole of the other label: beside it, not inside it
        if float(np.median(height[part])) > float(np.median(height[wall_cells])) - FLOOR_STEP_M:
            continue  # it stands as high as its wall or higher: an object lying in the vessel, or a look-alike
        wall_lab = np.median(weighted_lab[wall_cells], axis=0)
        if float(np.linalg.norm(np.median(weighted_lab[part], axis=0) - wall_lab)) >= colour_edge:
            continue  # another colour: another object
        out[part] = wall
    return out
