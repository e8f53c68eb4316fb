"""Scoring the segments of a view against a tracked target's record (pg_policy.perception.target_tracker).

A segment is scored at each predicted place of the target (a mask and its centroid, in cells) by the terms of
pg_policy.perception.target_appearance.match_terms, colour, form, overlap and nearness, each in [0, 1]: the score is
W_COLOUR * colour + W_FORM * form + W_PLACE * max(overlap, nearness). A segment whose centroid lies beyond the gate
of a place is not scored there, nor one whose colour term stays under COLOUR_FLOOR. A segment of more than
MERGE_RATIO times the record's area (where the record is partly covered, more than UNCOVERED_MAX_M2 too) that
overlaps the predicted mask is the target merged with a touching neighbour of its colour: it is scored as its cells
within CROP_CELLS of the predicted mask ("merged"). When no whole segment scores SURE_SCORE, or the best one's form
term stays under SHAPE_FORM, a look-alike may share the target's segment: every segment of more than SHAPE_RATIO
times the record's area is also scored cut to the target's outline (pg_policy.perception.template_cut,
`look_alike_cut`) where that cut stands as high as the record (median and top within SHAPE_HEIGHT_M: the same face
up) ("shaped").

Frames and units: masks are (H, W) bool over the heightmap cells; centroids (row, col) in cells; heights in metres.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np

from pg_core.heightmap import Heightmap
from pg_policy.perception.segmentation import MIN_OBJECT_CELLS
from pg_policy.perception.target_appearance import Appearance, describe, match_terms
from pg_policy.perception.template_cut import Template, look_alike_cut, placements

W_COLOUR, W_FORM, W_PLACE = 0.3, 0.3, 0.4  # weights of the terms (sum 1)
SURE_SCORE = 0.65  # a found target scoring below this is unsure (target_tracker)
COLOUR_FLOOR = 0.4  # a segment whose colour term stays under this is not the target (measured on training
# sequences: the target's own term stays above 0.54, shading and tilt included)
MERGE_RATIO = 3.5  # a segment over this many times the reference area that overlaps the prediction is merged (a
# target partly covered in its first view grows as a push uncovers it: at 1.8 most "merges" were such targets)
CROP_CELLS = 3  # a merged segment is cut to its cells within this many cells of the predicted mask
UNCOVERED_MAX_M2 = 0.0025  # a partly covered record may grow to this area (m^2; 5 x 5 cm) as a cover leaves
SHAPE_RATIO = 1.5  # a segment over this many times the reference area is cut to the target's shape where it fits
SHAPE_FORM = 0.75  # ... tried when the best whole segment scores under SURE_SCORE or its form term under this
SHAPE_HEIGHT_M = 0.004  # ... and the cut stands as high as the reference within this (m): the same face up

Place = tuple[np.ndarray, tuple[float, float]]  # a predicted mask and its centroid (row, col)
Scored = tuple[float, int, tuple, np.ndarray, str]  # score, -label, terms, mask, how


@dataclass(frozen=True)
class SegmentScorer:
    """Scores segments against `reference` (the tracked target's record), its outline `template` (None: no cut to
    the outline) on heightmaps of `resolution` m per cell."""

    reference: Appearance
    template: Template | None
    resolution: float

    def score(self, hm: Heightmap, labels: np.ndarray, lab: np.ndarray, others: np.ndarray,
              places: list[Place], gate: float) -> list[Scored]:
        """(score, -label, terms, mask, how) of every segment of `labels` less the (H, W) bool `others` whose
        centroid lies within `gate` cells of a predicted place (`places`: (mask, centroid) pairs), best first, each
        segment once (its better place) after the best; `how`: "merged" (cut to the predicted place), "shaped" (cut
        to the target's outline) or ""."""
        ref = self.reference
        grow = np.ones((2 * CROP_CELLS + 1,) * 2, np.uint8)
        merge_cells = MERGE_RATIO * ref.area
        if ref.partial:  # more of it may come into view: a segment of an uncovered target's size is not a merge
            merge_cells = max(merge_cells, UNCOVERED_MAX_M2 / self.resolution**2)
        scored, shapes = [], []
        for label in range(1, int(labels.max()) + 1):
            whole = (labels == label) & ~others
            if whole.sum() < MIN_OBJECT_CELLS:
                continue
            if whole.sum() > SHAPE_RATIO * ref.area:
                shapes.append((label, whole))
            for predicted, expected in places:
                merged = int(whole.sum()) > merge_cells and bool((whole & predicted).any())
                seg = whole & (cv2.dilate(predicted.astype(np.uint8), grow) > 0) if merged else whole
                score, terms = self.terms(hm, seg, lab, predicted, expected, gate)
                if score is not None:
                    scored.append((score, -label, terms, seg, "merged" if merged else ""))
        best = max(scored, key=lambda s: s[0], default=None)
        if best is None or best[0] < SURE_SCORE or best[2][1] < SHAPE_FORM:  # a look-alike may share its segment
            scored += self.shaped(hm, lab, shapes, places, gate)
        scored = sorted(scored, key=lambda s: (s[0], s[1]), reverse=True)
        return [s for k, s in enumerate(scored) if k == 0 or s[1] != scored[0][1]]  # runner-up: another segment

    def shaped(self, hm: Heightmap, lab: np.ndarray, shapes: list[tuple[int, np.ndarray]], places: list[Place],
               gate: float) -> list[Scored]:
        """`score`'s entries of the segments `shapes` ((label, cells), each over SHAPE_RATIO times the reference's
        area) cut to the target's outline (pg_policy.perception.template_cut.look_alike_cut) at each place, where
        the cut stands as high as the reference (`as_high`)."""
        if self.template is None or self.reference.partial:
            return []
        out = []
        for label, whole in shapes:
            fits = placements(whole, self.template)
            for predicted, expected in places if fits else []:
                shaped = look_alike_cut(whole, self.template, expected, predicted, fits)
                if shaped is None or not self.as_high(describe(hm, shaped, lab)):
                    continue
                score, terms = self.terms(hm, shaped, lab, predicted, expected, gate)
                if score is not None:
                    out.append((score, -label, terms, shaped, "shaped"))
        return out

    def as_high(self, seen: Appearance) -> bool:
        """Whether `seen` stands as high as the reference (median and top within SHAPE_HEIGHT_M): a cut to the
        target's outline is the target only where it still lies on the same face."""
        return (abs(seen.height - self.reference.height) <= SHAPE_HEIGHT_M
                and abs(seen.top - self.reference.top) <= SHAPE_HEIGHT_M)

    def terms(self, hm: Heightmap, seg: np.ndarray, lab: np.ndarray, predicted: np.ndarray,
              expected: tuple[float, float], gate: float) -> tuple[float | None, tuple | None]:
        """(score, terms) of the candidate `seg` against the reference at one predicted place; (None, None) when its
        centroid lies beyond `gate` cells of `expected` or its colour term under COLOUR_FLOOR."""
        seen = describe(hm, seg, lab)
        if math.hypot(seen.centroid[0] - expected[0], seen.centroid[1] - expected[1]) > gate:
            return None, None
        terms = match_terms(self.reference, seen, seg, predicted, expected, self.resolution)
        if terms[0] < COLOUR_FLOOR:
            return None, None
        return W_COLOUR * terms[0] + W_FORM * terms[1] + W_PLACE * max(terms[2], terms[3]), terms
