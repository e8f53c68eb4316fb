"""Keeping a target named by a mask on the same object from one heightmap to the next, without a colour palette.

`TargetTracker.start(hm, mask)` records the target's appearance in its first view
(pg_policy.perception.target_appearance: median CIE Lab colour, area, heights, shape, whether it is partly covered)
and its place (the mask).
`update(hm, shift_xy)` segments each new heightmap (pg_policy.perception.segmentation.segment_objects) and first
compares it with the heightmap the target was last found in (pg_policy.perception.view_change: a cell is unchanged when
its height stays within 3 mm and its colour within 10 Lab units). When STAY_FRACTION of the last mask is unchanged, the
target did not move (the action went elsewhere): it keeps its unchanged cells and takes in the cells of the segments
they mostly fill that did not rise (something moved in there); where those hold more than IN_PLACE_RATIO times the
reference's area (a look-alike lies against it, in one segment) it keeps its unchanged cells alone. It also takes in the
cells of its segments that a removed cover laid bare (lower than before, or unseen before) and of its colour (within
COLOUR_EDGE of the first view's), connected to it, up to UNCOVERED_MAX_M2 if that is more: a target mostly covered in
its first view grows to what a push uncovers, and not into a merged neighbour of its colour that moved. Its form (area,
heights, shape) then becomes the reference. When no push was predicted to move it and its cells are unchanged or lie
under another object that moved onto it (they rose and changed colour), it is "partly covered": its visible part; with
too little of it in view, "covered": an empty, unsure track, the last view kept to compare the next with, so that it is
in place again once the cover leaves. An "in place" or "partly covered" track is as sure as the last track that found
the target: it says the object did not move, not that it is the target.

Otherwise the target moved, and every segment, less the unchanged cells that were not the target's (neighbours
that did not move: unchanged cells of a segment of the last view that kept UNMOVED_FRACTION of its cells; where a
look-alike of the target's colour and height moved away, its old cells look unchanged under the target that moved
in), is scored against the first view's record (pg_policy.perception.segment_scores, where the weights and the
thresholds of the scoring are); when none is found so, every whole segment is (the last mask was another object,
which a grasp lifted: the target stayed where it was). Each term lies in [0, 1]
(pg_policy.perception.target_appearance.match_terms, where the scales are):

- colour: exp(-dE / COLOUR_SCALE), dE the CIE94 colour difference (`delta_e94`) with lightness weighted by
  LIGHTNESS_WEIGHT: shading and a tilted face change lightness and chroma together and leave the hue, which CIE94
  weighs most for saturated colours;
- form: the mean of the height term exp(-dh / HEIGHT_SCALE_M) (dh: the mean absolute difference of the median and
  the top height), the area ratio min/max, and the shape term exp(-|d hu1| / HU1_SCALE - |d ratio| / RATIO_SCALE
  - max(|d extent| - EXTENT_SLACK, 0) / EXTENT_SCALE) (first Hu moment, minor/major axis ratio and extent, the area
  over the smallest enclosing rectangle's: invariant to rotation and translation; a disc and a square alike in the
  first two differ in the third); when the record is partly
  covered (more of the target may come into view), a larger segment's area and shape terms are UNKNOWN_TERM;
- place: the larger of the overlap, IoU of the segment with the last mask moved by `shift_xy` (the displacement a
  push predicts), and the nearness exp(-d / DISTANCE_SCALE_M), d the distance between the segment's centroid and
  the predicted one. A segment whose colour term stays under COLOUR_FLOOR is never the target.

Two guards keep a track from jumping. A segment whose centroid lies farther than GATE_M plus the predicted
displacement from the predicted centroid is not the target (a push carries an object push_length at most; a failed
grasp moves it a few centimetres). A segment more than MERGE_RATIO times the reference's area (and, where the
record is partly covered, more than UNCOVERED_MAX_M2: a target uncovered whole) that overlaps
the predicted mask (the target merged with a touching neighbour of its colour) is cut to the cells within
CROP_CELLS of the predicted mask, and the track is unsure. A target pushed against a look-alike of its colour and
height shares its segment with it: when no whole segment scores SURE_SCORE, or the best one's form term stays under
SHAPE_FORM, every segment over SHAPE_RATIO times the reference's area is also scored cut to the target's outline
(its cells in the view its form was recorded from, turned and shifted to where it fits the segment nearest the
predicted place, standing as high as the record: pg_policy.perception.template_cut), "cut to its shape" in the
track's note. A segment found or re-found whole that holds more than SHAPE_RATIO times the reference's area (a
look-alike joined it in one segment, which the scores alone do not tell) is cut the same way when the cut runs along
a seam (template_cut.seam_cut: a step in height or colour where the two meet; a cut through one object shows none),
"a look-alike cut off along a seam" in the note. A predicted displacement may be too long (the push met other
objects, missed the target or turned it), so every segment is scored against the places at PATH_FRACTIONS of it,
from the full displacement to where the target was last seen, unmoved, and keeps the best.

The score is the weighted mean (W_COLOUR, W_FORM, W_PLACE); the best segment is the target when its score reaches
FOUND_SCORE. When none does and unsure tracks have led away from where a sure track last saw the target (onto a
look-alike, which a grasp may then have lifted), the segments are scored against that place, unmoved, and the best
reaching FOUND_SCORE is the target, unsure ("where it was last sure"). When no segment is found near the expected
place (the target was carried farther than predicted, or the track followed a neighbour that was then lifted away),
the target is looked for anywhere by appearance alone among the segments that moved since it was last found (a
segment with UNMOVED_FRACTION of its cells unchanged since that view did not move, and the target did): the one
whose mean of colour and form reaches REFIND_SCORE (pg_policy.perception.refind) with no other within
REFIND_MARGIN of it is re-found, unsure
("re-found by appearance");
objects alike in colour and form are not re-found this way. When none of those is, every segment is, the unmoved
ones too (the track that last found the target followed another object, which an action then lifted or carried off,
and the target stayed where it was: "re-found by appearance among all objects"); failing that, the one segment whose
colour term reaches REFIND_COLOUR, every other's staying under COLOUR_FLOOR, is the target, unsure (turned onto
another face, or merged with a neighbour of another colour: "re-found as the one object of its colour"). Failing
that too, when nothing lies where the target was last found (fewer than MIN_SEARCH_CELLS object cells within
SEARCH_RADIUS_M of its last mask, the target memory's test: the track followed a look-alike that a grasp then
lifted, or a push carried the target off), the look-alike (colour and form reaching REFIND_SCORE) nearest where the
target was last sure is taken, unsure ("re-found as the look-alike nearest where it was last sure"); with something
lying there the target may be under it, and the track stays empty. A found track is unsure when its score stays
under SURE_SCORE or the runner-up comes within MARGIN of it. Objects of one colour are told apart by form and place
alone. The appearance stays that of the first view; the place follows every found track. A target not found
leaves the place where it was last seen.

A target named by a point keeps that point's cell (`start`'s `anchor`) while it has not been seen to move. A first
mask can hold a look-alike beside the target (one colour, one height, no gap between them: one segment); when an
action moves the look-alike away, the segment at the anchor, mostly within the last mask and unchanged, and now
smaller than it, is the target ("in place: the clicked part"), and its form becomes the reference. A track found by the
moved path or re-found drops the anchor.

Frames and units: masks are (H, W) bool over the heightmap cells (pg_core.heightmap: rows along y, columns along x);
`shift_xy` is (dx, dy) metres in `world`; heights and distances in metres. Deterministic: the same heightmaps give
the same tracks. Raised: ValueError for a mask whose shape differs from the heightmap's or that holds no cell;
RuntimeError for `update` before `start`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import cv2
import numpy as np

from pg_core.heightmap import OBJECT_HEIGHT_M, Heightmap
from pg_core.target_mask import dilate_mask
from pg_policy.perception.refind import refind
from pg_policy.perception.segment_scores import SHAPE_RATIO, SURE_SCORE, UNCOVERED_MAX_M2, SegmentScorer
from pg_policy.perception.segmentation import (
    COLOUR_EDGE,
    LIGHTNESS_WEIGHT,
    MIN_OBJECT_CELLS,
    lab_image,
    segment_objects,
)
from pg_policy.perception.target_appearance import Appearance, describe, partly_covered, shifted
from pg_policy.perception.target_memory import MIN_SEARCH_CELLS, SEARCH_RADIUS_M
from pg_policy.perception.template_cut import Template, seam_cut
from pg_policy.perception.view_change import view_change

FOUND_SCORE = 0.45  # a best segment scoring below this is not the target: the target is hidden
MARGIN = 0.08  # a runner-up scoring within this of the best makes the track unsure
GATE_M = 0.12  # a segment's centroid this far (m) beyond the predicted displacement from the predicted one: not it
PATH_FRACTIONS = (1.0, 2 / 3, 1 / 3, 0.0)  # places along a predicted displacement a moved target is scored at
UNMOVED_FRACTION = 0.5  # a segment with this share of its cells unchanged since the target was last found: unmoved
STAY_FRACTION = 0.85  # the target did not move when at least this fraction of its last mask is unchanged
IN_PLACE_RATIO = 2.5  # a target in place grows by what a cover laid bare to at most this many times the reference
# area (half covered: 2), or to UNCOVERED_MAX_M2 (segment_scores) if that is more
SEGMENT_GROW_RATIO = 2.0  # ... and by cells of its segments that were in view before to at most this many times


@dataclass(frozen=True, eq=False)
class Track:
    """One observation's target: mask (H, W) bool (empty: not found, hidden), confidence in [0, 1] (the best
    segment's score), unsure (too low a score or a close runner-up) and why (one line for the decision record)."""

    mask: np.ndarray
    confidence: float
    unsure: bool
    why: str


def _check_mask(hm: Heightmap, mask: np.ndarray) -> np.ndarray:
    mask = np.asarray(mask)
    if mask.shape != np.asarray(hm.height).shape:
        raise ValueError(f"mask shape {mask.shape} differs from the heightmap's {np.asarray(hm.height).shape}")
    mask = mask.astype(bool)
    if not mask.any():
        raise ValueError("mask holds no cell")
    return mask


class TargetTracker:
    """Follows one object through successive heightmaps of the same grid (see the module docstring)."""

    def __init__(self) -> None:
        self.reference: Appearance | None = None  # the first view's appearance
        self.last_mask: np.ndarray | None = None  # where the target was last seen ((H, W) bool)
        self.resolution = 0.0  # m per cell of the heightmaps tracked
        self.last_hm: Heightmap | None = None  # the heightmap last_mask was found in
        self.last_lab: np.ndarray | None = None  # its Lab image ((H, W, 3) float32)
        self.sure_mask: np.ndarray | None = None  # where the target was last seen by a sure track ((H, W) bool)
        self.unsure = False  # whether the latest track that found the target was unsure
        self.last_labels: np.ndarray | None = None  # segment_objects(last_hm), None until needed
        self._segmented: tuple[Heightmap, np.ndarray] | None = None  # the heightmap `update` segments, its labels
        self.anchor: tuple[int, int] | None = None  # the cell a point named, while the target has not moved
        self.template: Template | None = None  # the reference's outline (pg_policy.perception.template_cut)

    def start(self, hm: Heightmap, mask: np.ndarray, anchor: tuple[int, int] | None = None) -> Track:
        """Record the target `mask` ((H, W) bool, non-empty) as seen in `hm`; returns it as a sure Track.
        anchor: the (row, col) cell a point named (kept only when it lies in `mask`; module docstring), None for
        none. Raises ValueError for a mask of another shape than the heightmap or without a cell, or an anchor off
        the grid."""
        mask = _check_mask(hm, mask)
        if anchor is not None and not (0 <= anchor[0] < mask.shape[0] and 0 <= anchor[1] < mask.shape[1]):
            raise ValueError(f"anchor {anchor} lies off the {mask.shape[0]} x {mask.shape[1]} grid")
        self.anchor = anchor if anchor is not None and bool(mask[anchor]) else None
        lab = lab_image(hm.color)
        self.reference = replace(describe(hm, mask, lab), partial=partly_covered(hm, mask))
        self.template = Template.of(mask)
        self._found(hm, mask, lab)
        self.sure_mask, self.unsure = mask.copy(), False
        self.resolution = float(hm.resolution)
        return Track(mask.copy(), 1.0, False, "first view")

    def update(self, hm: Heightmap, shift_xy: tuple[float, float] | None = None) -> Track:
        """The target in `hm`: the best-scoring segment, or an empty mask when none reaches FOUND_SCORE.

        shift_xy: the target's predicted displacement (dx, dy) in `world` metres since the last heightmap (e.g. a
        push's), None when unknown (no move predicted). Raises RuntimeError before `start`, ValueError for a
        heightmap of another grid than the first."""
        if self.reference is None or self.last_mask is None:
            raise RuntimeError("TargetTracker.update before start")
        if np.asarray(hm.height).shape != self.last_mask.shape:
            raise ValueError(f"heightmap {np.asarray(hm.height).shape} differs from the tracked grid "
                             f"{self.last_mask.shape}")
        track = self._track(hm, shift_xy)
        if not track.unsure and track.mask.any():
            self.sure_mask = track.mask.copy()
        if track.mask.any():
            self.unsure = track.unsure
        return track

    def _track(self, hm: Heightmap, shift_xy: tuple[float, float] | None) -> Track:
        """`update` past its checks."""
        assert self.reference is not None and self.last_mask is not None and self.sure_mask is not None
        dx, dy = shift_xy if shift_xy is not None else (0.0, 0.0)
        lab = lab_image(hm.color)
        labels = segment_objects(hm, lab)
        self._segmented = (hm, labels)
        if labels.max() == 0:
            return Track(np.zeros_like(self.last_mask), 0.0, True, "no object in view")
        assert self.last_hm is not None and self.last_lab is not None
        still, arrived, uncovered, recoloured = view_change(self.last_hm, self.last_lab, hm, lab)
        stay = self.last_mask & still
        if stay.sum() >= STAY_FRACTION * self.last_mask.sum():
            return self._in_place(hm, labels, lab, stay, arrived, uncovered)
        covered = self.last_mask & arrived & recoloured  # another object on it (the target tilting keeps its colour)
        if not (dx or dy) and (stay | covered).sum() >= STAY_FRACTION * self.last_mask.sum():
            return self._covered(hm, lab, stay, covered)
        clicked = self._clicked_part(hm, labels, lab, stay)
        if clicked is not None:
            return clicked
        others = still & ~self.last_mask & self._stayed(still)  # cells of other objects that did not move
        cen = describe(hm, self.last_mask, lab).centroid
        gate = (GATE_M + math.hypot(dx, dy)) / self.resolution  # cells
        # where the target should be: moved as predicted, and (a push may carry it less far: it meets other
        # objects, turns, slides past) at PATH_FRACTIONS of that displacement, down to where it was
        places = [(shifted(self.last_mask, round(f * dy / self.resolution), round(f * dx / self.resolution)),
                   (cen[0] + f * dy / self.resolution, cen[1] + f * dx / self.resolution))
                  for f in (PATH_FRACTIONS if dx or dy else (1.0,))]
        scored = self._scorer().score(hm, labels, lab, others, places, gate)
        if not scored or scored[0][0] < FOUND_SCORE:  # the last mask was another object, lifted: the target stayed
            scored = self._scorer().score(hm, labels, lab, np.zeros_like(others), places, gate)
        where = ""
        if (not scored or scored[0][0] < FOUND_SCORE) and not np.array_equal(self.sure_mask, self.last_mask):
            # unsure tracks since led elsewhere (a look-alike): look where the target was last sure
            sure = [(self.sure_mask, describe(hm, self.sure_mask, lab).centroid)]
            again = self._scorer().score(hm, labels, lab, np.zeros_like(others), sure, GATE_M / self.resolution)
            if again and again[0][0] >= FOUND_SCORE:
                scored, where = again, "where it was last sure: "
        if not scored:
            return self._refind(hm, labels, lab, others, f"no object within {GATE_M + math.hypot(dx, dy):.2f} m "
                                "of where it was expected")
        best, terms, mask, how = scored[0][0], scored[0][2], scored[0][3], scored[0][4]
        detail = "colour {:.2f} form {:.2f} overlap {:.2f} near {:.2f}".format(*terms)
        if best < FOUND_SCORE:
            return self._refind(hm, labels, lab, others, f"best segment scores {best:.2f} < {FOUND_SCORE} ({detail})")
        mask, seam = self._trim(hm, mask, lab, places[0][1])
        self._found(hm, mask, lab)
        self.anchor = None  # found where it moved to: the named cell no longer marks it
        runner = scored[1][0] if len(scored) > 1 else 0.0
        detail += seam
        if how == "merged":
            return Track(mask, float(best), True,
                         f"{where}merged with a touching object: cut to the predicted place ({detail})")
        if how == "shaped":
            detail += "; cut to its shape from a segment it shares"
        if best < SURE_SCORE:
            return Track(mask, float(best), True, f"{where}weak match {best:.2f} < {SURE_SCORE} ({detail})")
        if where:
            return Track(mask, float(best), True, f"{where}match {best:.2f} ({detail})")
        if best - runner < MARGIN:
            return Track(mask, float(best), True, f"ambiguous: runner-up scores {runner:.2f} against {best:.2f}{seam}")
        return Track(mask, float(best), False, f"match {best:.2f} ({detail})")

    def _scorer(self) -> SegmentScorer:
        """The scorer of segments against the current reference (pg_policy.perception.segment_scores)."""
        assert self.reference is not None
        return SegmentScorer(self.reference, self.template, self.resolution)

    def _in_place(self, hm: Heightmap, labels: np.ndarray, lab: np.ndarray, stay: np.ndarray,
                  arrived: np.ndarray, uncovered: np.ndarray) -> Track:
        """The target that did not move (STAY_FRACTION of its last mask unchanged): its unchanged cells `stay`, the
        cells of the segments they mostly fill that did not rise (a rise is something that moved in) and the
        `uncovered` cells of its colour (lower than before, or unseen before) of the segments `stay` lies in (what a
        removed cover laid bare), connected to `stay`; the first of those with the uncovered cells, without the
        segments' other cells, or without the uncovered cells that stays within its limit: UNCOVERED_MAX_M2 or
        SEGMENT_GROW_RATIO times the reference's area, whichever is more, where it takes in segment cells that
        were in view before (they were not the target's then), IN_PLACE_RATIO times it for the uncovered cells
        alone; else `stay` alone (a look-alike lies against it, in one segment). When it grew so, the form of the
        reference follows it (the colour stays the first view's)."""
        assert self.reference is not None
        segs, bared = np.zeros_like(stay), np.zeros_like(stay)
        weights = np.array([LIGHTNESS_WEIGHT, 1.0, 1.0], np.float32)
        alike = np.linalg.norm((lab - self.reference.lab.astype(np.float32)) * weights, axis=-1) < COLOUR_EDGE
        for label in np.unique(labels[stay]):
            seg = labels == label
            if label:
                bared |= seg & uncovered & alike
            if label and 2 * int((seg & stay).sum()) >= min(int(seg.sum()), int(stay.sum())):
                segs |= seg
        grown = stay | (segs & ~arrived)
        uncovered_max = UNCOVERED_MAX_M2 / self.resolution**2
        limit = max(IN_PLACE_RATIO * self.reference.area, uncovered_max)
        grow_limit = max(SEGMENT_GROW_RATIO * self.reference.area, uncovered_max)
        mask, whole = stay, False
        for candidate, most in ((grown | bared, grow_limit), (stay | bared, limit), (grown, grow_limit)):
            _, parts = cv2.connectedComponents(candidate.astype(np.uint8), connectivity=8)
            part = np.isin(parts, np.unique(parts[stay]))
            if part.sum() <= most:
                mask, whole = part, True
                break
        if whole:
            seen = describe(hm, mask, lab)
            self.reference = replace(seen, lab=self.reference.lab, partial=partly_covered(hm, mask))
            self.template = Template.of(mask)
        left_out = ", a touching object left out" if (segs & ~mask).sum() >= MIN_OBJECT_CELLS else ""
        taken = int((mask & bared & ~stay).sum())
        grew = f", {taken} cells uncovered" if taken >= MIN_OBJECT_CELLS else ""
        share = 100 * stay.sum() / max(int(self.last_mask.sum()), 1)
        self._found(hm, mask, lab)
        return Track(mask.copy(), 1.0, self.unsure, f"in place: {share:.0f} % of its cells unchanged{grew}{left_out}")

    def _clicked_part(self, hm: Heightmap, labels: np.ndarray, lab: np.ndarray, stay: np.ndarray) -> Track | None:
        """The segment at the anchor, when the anchor's cell is unchanged (in `stay`, the last mask's unchanged
        cells) and the segment lies mostly within the last mask and unchanged (UNMOVED_FRACTION of its cells in
        each: a push that nudged the target leaves it so) and is smaller than STAY_FRACTION of it: the named
        object, from which a look-alike that shared its segment moved away (module docstring); None otherwise. Its
        form becomes the reference."""
        assert self.reference is not None and self.last_mask is not None
        if self.anchor is None or not labels[self.anchor] or not stay[self.anchor]:
            return None
        seg = labels == labels[self.anchor]
        size = int(seg.sum())
        if ((seg & self.last_mask).sum() < UNMOVED_FRACTION * size or (seg & stay).sum() < UNMOVED_FRACTION * size
                or size >= STAY_FRACTION * self.last_mask.sum()):
            return None
        self.reference = replace(describe(hm, seg, lab), lab=self.reference.lab, partial=partly_covered(hm, seg))
        self.template = Template.of(seg)
        share = 100 * size / max(int(self.last_mask.sum()), 1)
        self._found(hm, seg, lab)
        return Track(seg.copy(), 1.0, self.unsure, f"in place: the clicked part ({share:.0f} % of the last mask), "
                     "a look-alike beside it moved away")

    def _covered(self, hm: Heightmap, lab: np.ndarray, stay: np.ndarray, covered: np.ndarray) -> Track:
        """The target no push was predicted to move whose cells are unchanged (`stay`) or lie under something that
        moved onto it (`covered`): its visible part `stay`, as sure as the track before; with fewer than
        MIN_OBJECT_CELLS of it in view, an empty track, and the view it was last found in is kept to compare the
        next one with (when the cover leaves, the target is "in place" again)."""
        assert self.last_mask is not None
        share = 100 * int(covered.sum()) / max(int(self.last_mask.sum()), 1)
        if stay.sum() < MIN_OBJECT_CELLS:
            return Track(np.zeros_like(stay), 0.0, True, f"covered: {share:.0f} % of its cells lie under something "
                         "that moved onto it")
        self._found(hm, stay, lab)
        return Track(stay.copy(), 1.0, self.unsure, f"partly covered: {share:.0f} % of its cells lie under "
                     "something that moved onto it")

    def _found(self, hm: Heightmap, mask: np.ndarray, lab: np.ndarray) -> None:
        """Remember `mask` as the target's place, seen in `hm` (`lab`: its Lab image)."""
        self.last_mask, self.last_hm, self.last_lab = mask.copy(), hm, lab
        self.last_labels = self._segmented[1] if self._segmented is not None and self._segmented[0] is hm else None

    def _bare(self, hm: Heightmap) -> bool:
        """Whether nothing lies where the target was last found in `hm`: fewer than MIN_SEARCH_CELLS object cells
        within SEARCH_RADIUS_M of the last mask (the target memory's test, pg_policy.perception.target_memory)."""
        assert self.last_mask is not None
        near = dilate_mask(self.last_mask, hm.resolution, SEARCH_RADIUS_M)
        return int((near & (np.asarray(hm.height) > OBJECT_HEIGHT_M)).sum()) < MIN_SEARCH_CELLS

    def _trim(self, hm: Heightmap, mask: np.ndarray, lab: np.ndarray,
              expected: tuple[float, float]) -> tuple[np.ndarray, str]:
        """(template_cut.seam_cut of `mask` nearest `expected` (row, col), a note) where `mask`, a segment found whole,
        holds over SHAPE_RATIO times the reference's area and the cut stands as high as it; else (`mask`, "")."""
        assert self.reference is not None
        if self.template is None or self.reference.partial or mask.sum() <= SHAPE_RATIO * self.reference.area:
            return mask, ""
        part = seam_cut(hm, lab, mask, self.template, expected)
        if part is None or not self._scorer().as_high(describe(hm, part, lab)):
            return mask, ""
        return part, "; a look-alike cut off along a seam"

    def _stayed(self, still: np.ndarray) -> np.ndarray:
        """(H, W) bool: the cells of the segments of the view the target was last found in that stayed, each with
        UNMOVED_FRACTION of its cells in `still` ((H, W) bool, `_changes`). A cell that looks unchanged in a segment
        that moved away is a look-alike that moved in (another object of its colour and height), not an object
        that stayed."""
        assert self.last_hm is not None
        if self.last_labels is None:
            self.last_labels = segment_objects(self.last_hm)
        labels = self.last_labels
        total = np.bincount(labels.ravel(), minlength=int(labels.max()) + 1)
        kept = np.bincount(labels[still].ravel(), minlength=total.size)
        stayed = kept >= UNMOVED_FRACTION * np.maximum(total, 1)
        stayed[0] = False
        return stayed[labels]

    def _refind(self, hm: Heightmap, labels: np.ndarray, lab: np.ndarray, others: np.ndarray, why: str) -> Track:
        """The target looked for anywhere by appearance (module docstring; pg_policy.perception.refind), `others`
        the (H, W) bool cells of other objects unchanged since it was last found; or an empty track saying `why`
        not."""
        assert self.reference is not None and self.last_mask is not None and self.sure_mask is not None
        found = refind(self.reference, hm, labels, lab, others, self.resolution, self.sure_mask, self._bare(hm),
                       UNMOVED_FRACTION)
        if found is None:
            return Track(np.zeros_like(self.last_mask), 0.0, True, f"not found: {why}")
        mask, score, how = found
        mask, seam = self._trim(hm, mask, lab, describe(hm, self.sure_mask, lab).centroid)
        self._found(hm, mask, lab)
        self.anchor = None
        return Track(mask, score, True, f"re-found {how}{seam}; not found near its place: {why})")
