"""How an evaluation trial names its target, and the target mask of each of its observations.

`--target-by` (TARGET_BY):
- ``colour``: the target's palette colour, as a colour request names it; each mask is
  pg_core.target_mask.target_mask of the colour (the runner's own path, unchanged);
- ``point``: a pg_policy.target_loop.target_spec.PointTarget at the centre of the simulator's ground-truth target
  mask of the first view: its centroid, or, when the centroid cell is not well inside the target (a hollow shape,
  a target seen in two pieces on both sides of an object lying across it, a 4 mm flat part), the innermost cell
  of the target, so the point lies where a user would click;
- ``mask``: a MaskTarget of that ground-truth mask of the first view.
After the first view the trial's TargetFollower tracks the target: no later ground truth reaches the policy.

`TrialTarget` holds one trial's follower: `observe(hm, truth)` gives the (H, W) bool mask of each observation and
keeps the record's view of it (`view`: IoU against `truth`, ground-truth cells, whether the tracker was unsure and
why); `acted(decision, result)` predicts the target's displacement by an executed push for the next update
(pg_policy.perception.push_shift, through TargetFollower.acted).

Frames and units: masks are (H, W) bool over the heightmap cells (pg_core.heightmap: rows along y, columns along x);
points, displacements and lengths in metres in `world`; a decision's yaw in radians (the push travels along
(cos yaw, sin yaw), pg_sim.world.primitives).
"""

from __future__ import annotations

import math
from typing import Any

import cv2
import numpy as np

from pg_core.heightmap import Heightmap, pixel_to_world
from pg_policy.models.click_segmentation import DEFAULT_SEGMENTER
from pg_policy.perception.segmentation import object_cells
from pg_policy.target_loop.target_spec import MaskTarget, PointTarget, TargetFollower
from pg_sim.world.recolour import UNIQUE

COLOUR, POINT, MASK = "colour", "point", "mask"
CLICK_MARGIN_CELLS = 2.0  # a point lies this far (cells) inside the target's border, or as far as its width allows
TARGET_BY = (COLOUR, POINT, MASK)


def check_target_by(target_by: str, colours: str) -> None:
    """ValueError for an unknown `target_by`, or for ``colour`` with a colour variant other than ``unique``: where
    colours repeat, a colour names no single object."""
    if target_by not in TARGET_BY:
        raise ValueError(f"unknown --target-by {target_by!r}; known: {', '.join(TARGET_BY)}")
    if target_by == COLOUR and colours != UNIQUE:
        raise ValueError(f"--target-by colour cannot name the target in scenes of --colours {colours}: the target's "
                         "colour is shared by other objects there; use --target-by point or --target-by mask")


def iou(a: np.ndarray, b: np.ndarray) -> float | None:
    """Intersection over union of two (H, W) bool masks; None when both are empty."""
    union = int(np.logical_or(a, b).sum())
    return int(np.logical_and(a, b).sum()) / union if union else None


def centre_point(hm: Heightmap, truth: np.ndarray) -> PointTarget:
    """The PointTarget at the centre of the non-empty (H, W) bool mask `truth` (module docstring: ``point``): its
    centroid when that cell holds an object of `truth` (segmentation.object_cells: a thin part of the table's colour is
    no place to click) CLICK_MARGIN_CELLS or more inside its border, else the innermost such cell (farthest from
    the border; of those, the nearest to the centroid): the middle of the target's largest visible piece, not the
    rim of a piece beside the object that hides its middle. Any cell of `truth` counts when none holds an object."""
    rows, cols = np.nonzero(truth)
    r, c = float(rows.mean()), float(cols.mean())
    cell = (int(math.floor(r)), int(math.floor(c)))
    on = truth & object_cells(hm)
    on = on if on.any() else truth
    inside = cv2.distanceTransform(np.pad(on, 1).astype(np.uint8), cv2.DIST_L2, 3)[1:-1, 1:-1]
    if inside[cell] < min(CLICK_MARGIN_CELLS, float(inside.max())):
        rows, cols = np.nonzero(inside >= inside.max() - 1e-6)
        k = int(np.argmin((rows - r) ** 2 + (cols - c) ** 2))
        r, c = float(rows[k]), float(cols[k])
    x, y = pixel_to_world(r, c, hm.bounds, hm.resolution)
    return PointTarget(x, y)


def first_spec(target_by: str, hm: Heightmap, truth: np.ndarray) -> PointTarget | MaskTarget:
    """The point or mask target of the first view `hm` from its ground-truth target mask `truth`. ValueError when
    the target is not seen in that view (nothing to point at)."""
    truth = np.asarray(truth, dtype=bool)
    if not truth.any():
        raise ValueError(f"--target-by {target_by}: the target is not visible in the first view (no ground-truth "
                         "target cell to point at)")
    return centre_point(hm, truth) if target_by == POINT else MaskTarget(truth.copy())


class TrialTarget:
    """The target masks of one trial named by ``point`` or ``mask`` (module docstring). `push_length`: m a push
    travels (the geometry's primitives.push_length); None: no displacement is predicted. `segmenter`: the learned
    segmenter joining a point's parts in the first view (pg_policy.models.click_segmentation.load_segmenter)."""

    def __init__(self, target_by: str, push_length: float | None = None, segmenter: str = DEFAULT_SEGMENTER) -> None:
        if target_by not in (POINT, MASK):
            raise ValueError(f"TrialTarget follows point or mask targets, got {target_by!r}")
        self.target_by = target_by
        self.push_length = push_length
        self.segmenter = segmenter
        self.follower: TargetFollower | None = None
        self.view: dict[str, Any] = {}

    def observe(self, hm: Heightmap, truth: np.ndarray, shift_xy: tuple[float, float] | None = None) -> np.ndarray:
        """(H, W) bool target mask of `hm` (empty: not seen); `truth` is the simulator's ground-truth target mask of
        the same view, used to name the target in the first view and to score every mask (`view`); shift_xy: the
        target's displacement since the last view when known (TargetFollower.mask), None: the predicted one.
        ValueError when the first view does not show the target or its point names no object."""
        truth = np.asarray(truth, dtype=bool)
        if self.follower is None:
            self.follower = TargetFollower(first_spec(self.target_by, hm, truth), self.push_length, self.segmenter)
        mask = np.asarray(self.follower.mask(hm, shift_xy), dtype=bool)
        score = iou(mask, truth)
        self.view = {"iou": None if score is None else round(score, 4), "truth_cells": int(truth.sum()),
                     "unsure": bool(self.follower.unsure), "why": str(self.follower.why)}
        return mask

    def acted(self, decision: Any, result: Any) -> None:
        """Tell the follower the action just taken (`decision`: primitive, x, y, yaw; `result`: refused), so that
        an executed push predicts the target's displacement for the next observation (TargetFollower.acted)."""
        if self.follower is not None:
            self.follower.acted(str(decision.primitive), float(decision.x), float(decision.y), float(decision.yaw),
                                not getattr(result, "refused", False))
