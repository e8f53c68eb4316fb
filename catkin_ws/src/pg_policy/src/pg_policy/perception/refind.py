"""Re-finding a lost target by appearance: which segment of a heightmap is the target when none lies near where it
was expected (pg_policy.perception.target_tracker's last resort, described in its module docstring).

Frames and units: masks and labels are (H, W) over the heightmap cells (pg_core.heightmap); `lab` is the Lab image
of the heightmap's colours (pg_policy.perception.segmentation.lab_image); resolution in metres per cell.
"""

from __future__ import annotations

import math

import numpy as np

from pg_core.heightmap import Heightmap
from pg_policy.perception.segment_scores import COLOUR_FLOOR
from pg_policy.perception.target_appearance import Appearance, describe, match_terms

REFIND_SCORE = 0.8  # a target not found near its place is re-found where colour and form alone score this much
REFIND_MARGIN = 0.15  # ... and no other segment comes within this of that score
REFIND_COLOUR = 0.7  # failing that, the one segment whose colour term reaches this, every other's under COLOUR_FLOOR


def refind(ref: Appearance, hm: Heightmap, labels: np.ndarray, lab: np.ndarray, others: np.ndarray,
           resolution: float, sure_mask: np.ndarray | None, bare: bool,
           unmoved_fraction: float) -> tuple[np.ndarray, float, str] | None:
    """(mask, score, how) of the segment of `labels` that is the target described by `ref`, or None:
    1. among the segments that moved (less than `unmoved_fraction` of their cells in `others`, the (H, W) bool cells
       of other objects unchanged since the target was last found), then among all segments: the one whose mean
       of colour and form reaches REFIND_SCORE with no other within REFIND_MARGIN of it;
    2. the one segment whose colour term reaches REFIND_COLOUR, every other's under COLOUR_FLOOR;
    3. when `bare` (nothing lies where the target was last found) and `sure_mask` is known: of the segments whose
       mean reaches REFIND_SCORE, the one nearest the centroid of `sure_mask`.
    `how` completes "re-found ..." in the track's note."""
    moved, still = [], []
    for label in range(1, int(labels.max()) + 1):
        seg = labels == label
        colour, form, _, _ = match_terms(ref, describe(hm, seg, lab), seg, seg, (0.0, 0.0), resolution)
        unmoved = (seg & others).sum() >= unmoved_fraction * seg.sum()
        (still if unmoved else moved).append(((colour + form) / 2.0, colour, form, seg))
    # the target moved (it is not where it was last found) unless that track followed another object, which an
    # action then lifted or carried off: the target may be any object
    for scored, among in ((moved, ""), (moved + still, " among all objects")):
        scored.sort(key=lambda s: s[0], reverse=True)
        if scored and scored[0][0] >= REFIND_SCORE and (len(scored) == 1 or
                                                        scored[0][0] - scored[1][0] >= REFIND_MARGIN):
            score, colour, form, mask = scored[0]
            return mask, float(score), f"by appearance{among} {score:.2f} (colour {colour:.2f} form {form:.2f}"
    # a target turned onto another face, or merged with a neighbour of another colour, keeps its colour: the
    # one segment of that colour, where no other comes near it
    ranked = sorted(moved + still, key=lambda s: s[1], reverse=True)
    if ranked and ranked[0][1] >= REFIND_COLOUR and (len(ranked) == 1 or ranked[1][1] < COLOUR_FLOOR):
        _, colour, form, mask = ranked[0]
        return mask, float(colour), f"as the one object of its colour (colour {colour:.2f} form {form:.2f}"
    # nothing lies where it was last found (the track followed a look-alike that a grasp lifted, or the target
    # was carried off): of the objects alike to it, the one nearest where it was last sure
    alike = [s for s in moved + still if s[0] >= REFIND_SCORE]
    if alike and sure_mask is not None and bare:
        sure = describe(hm, sure_mask, lab).centroid
        score, colour, form, mask = min(alike, key=lambda s: math.dist(describe(hm, s[3], lab).centroid, sure))
        return mask, float(score), (f"as the look-alike nearest where it was last sure {score:.2f} (colour "
                                    f"{colour:.2f} form {form:.2f}")
    return None
