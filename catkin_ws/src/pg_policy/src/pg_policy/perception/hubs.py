"""A raised hub joins the dome it crowns: one object, not a disc standing on a ring.

Segmentation (pg_policy.perception.segmentation) splits objects at height steps; an object whose middle is a raised
hub or plateau on a body that falls away from it on every side (a toothed dish upside down, a cake stand, a lid's
knob on its lid) steps where the hub meets the body, so the hub becomes a label of its own that the body's label
mostly surrounds. A click at such an object's middle then names the hub alone. `join_hubs` gives each such hub to
the body around it: a label whose outer border (the cells within GAP_CELLS around it, its own holes filled) lies,
for at least ENCLOSED_SHARE of its cells, on one other label and for at most TABLE_SHARE on none; whose median
colour is within `colour_edge` of that label's (chroma weighted Lab, as the segmentation measures it); that stands
above that label at its edge by no more than STEP_M (the medians of its edge cells and of the body's cells on its
border); and around which that label falls away: the body's cells on the hub's border stand FALL_M or more above
the body's cells farther than FAR_CELLS from the hub (medians). An object lying in a vessel stands on the vessel's
floor, its lowest part, so the vessel rises away from it and it stays apart; a look-alike leaning on a block, or
lying beside it, borders it on one side only and stays apart.

Frames and units: labels (H, W) int32 (0: table or unseen), heights (H, W) float32 m above the table, colours
(H, W, 3) float32 Lab weighted as the caller compares colours. Deterministic.
"""

from __future__ import annotations

import cv2
import numpy as np
from scipy import ndimage

ENCLOSED_SHARE = 0.6  # this share of a hub's outer border on the body's label (the rest: objects lying on the body)
TABLE_SHARE = 0.2  # ... and at most this share on no label: a hub is surrounded by its body, not by the table
GAP_CELLS = 3  # the border: the cells within this many cells of the label
STEP_M = 0.01  # a hub stands at most this much (m) above the body's cells on its border (medians)
FALL_M = 0.015  # the body's cells on the hub's border stand this much (m) above its cells far from the hub
FAR_CELLS = 10  # body cells farther than this from the hub (cells) are "far" from it
MIN_HUB_CELLS = 20  # smaller labels are not joined (speckle; the segmentation's MIN_OBJECT_CELLS)


def join_hubs(labels: np.ndarray, height: np.ndarray, weighted_lab: np.ndarray, colour_edge: float) -> np.ndarray:
    """(H, W) int32: `labels` with every raised hub (module docstring) relabelled as the body around it; labels are
    not renumbered."""
    out = labels.copy()
    far_kernel = np.ones((2 * FAR_CELLS + 1,) * 2, np.uint8)
    grow = np.ones((2 * GAP_CELLS + 1,) * 2, np.uint8)
    edge_kernel = np.ones((3, 3), np.uint8)
    boxes = ndimage.find_objects(labels)
    for index, box in enumerate(boxes):
        label = index + 1
        if box is None:
            continue
        (r0, r1), (c0, c1) = ((b.start - GAP_CELLS, b.stop + GAP_CELLS) for b in box)
        if r0 < 0 or c0 < 0 or r1 > out.shape[0] or c1 > out.shape[1]:
            continue  # at the heightmap's edge: not seen surrounded
        window = out[r0:r1, c0:c1]  # the label and the ring around it (every cell within GAP_CELLS of it)
        part = window == label
        if int(part.sum()) < MIN_HUB_CELLS:
            continue
        filled = ndimage.binary_fill_holes(part)
        ring = cv2.dilate(filled.astype(np.uint8), grow).astype(bool) & ~filled
        around = window[ring]
        owners, counts = np.unique(around, return_counts=True)
        if int(counts[owners == 0].sum()) > TABLE_SHARE * around.size:
            continue
        counts[owners == 0] = 0
        body = int(owners[np.argmax(counts)])
        if body in (0, label) or counts.max() < ENCLOSED_SHARE * around.size:
            continue
        near_h = float(np.median(height[r0:r1, c0:c1][ring & (window == body)]))
        edge = part & cv2.dilate((~part).astype(np.uint8), edge_kernel).astype(bool)
        step = float(np.median(height[r0:r1, c0:c1][edge])) - near_h
        if not 0.0 <= step <= STEP_M:
            continue  # lower than the body round it (a floor) or far above it (an object standing on it)
        body_cells = out == body
        far = body_cells.copy()  # the body's cells farther than FAR_CELLS from the hub
        f0, f1 = max(r0 - FAR_CELLS, 0), min(r1 + FAR_CELLS, out.shape[0])
        g0, g1 = max(c0 - FAR_CELLS, 0), min(c1 + FAR_CELLS, out.shape[1])
        hub = out[f0:f1, g0:g1] == label
        far[f0:f1, g0:g1] &= ~cv2.dilate(hub.astype(np.uint8), far_kernel).astype(bool)
        if not far.any() or near_h < float(np.median(height[far])) + FALL_M:
            continue  # the body does not fall away from it: an object lying on a vessel's floor or a flat top
        hub_cells = out == label
        body_lab = np.median(weighted_lab[body_cells], axis=0)
        if float(np.linalg.norm(np.median(weighted_lab[hub_cells], axis=0) - body_lab)) >= colour_edge:
            continue  # another colour: another object
        out[hub_cells] = body
    return out
