"""Cutting a tracked target out of a segment it shares with look-alikes, by the target's own shape.

Touching objects of one colour and one height are one segment (pg_policy.perception.segmentation); after a push the
target can lie in such a segment with a look-alike. A rigid object keeps its outline from view to view up to a
rotation and a shift, so the target's record (`Template.of`: its cells in the view its form was recorded from,
cropped; only a block-like record, MIN_SOLIDITY) is placed in the segment at every rotation of ANGLE_STEP_DEG and
every shift (OpenCV's matchTemplate counts the template's cells that land on the segment), and the placements that
FIT_MIN of the template's cells land on are the places the target can be. `cut` takes the one whose centroid lies
nearest the place the target is expected at (the tracker's predicted place): the segment's cells within one cell of
that placement. `look_alike_cut` keeps such a cut only where it is evidence of a look-alike: the segment meets the
predicted mask and the cut leaves a connected piece of at least REST_MIN times the template's area (a target that
merely shows more of itself than in its record, turned onto a larger face, leaves less).
`seam_cut` keeps a look-alike cut only where it runs along a seam: look-alikes that touch in one segment (their
colours and heights alike enough for the segmentation to join them) still differ across the line where they meet, by
SEAM_HEIGHT_M in the median height or SEAM_COLOUR in the median Lab colour of the cells on either side, a few cells
from the line; a cut through one object shows no such step (identical blocks touching seamlessly show none either:
no view tells which one is the target).

Frames and units: masks are (H, W) bool over heightmap cells (rows along y, columns along x); centroids are
(row, col) in cells. Deterministic. Raised: ValueError for an empty template mask.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from pg_core.heightmap import Heightmap
from pg_policy.perception.segmentation import solidity

ANGLE_STEP_DEG = 7.5  # rotations of the template tried, over the full turn (an asymmetric outline: a triangle)
FIT_MIN = 0.9  # a placement fits when this share of the template's cells lands on the segment
REST_MIN = 0.8  # what the cut leaves holds a piece of at least this many times the template's area (a look-alike)
MIN_TEMPLATE_CELLS = 40  # smaller records (a sliver) give no template: too many places fit them
SEAM_HEIGHT_M = 0.0005  # a seam: the cells on either side of a cut differ this much in median height (m) ...
SEAM_COLOUR = 3.0  # ... or this much in median colour (Euclidean distance in CIE Lab)
SEAM_BAND_CELLS = (1.5, 3.5)  # ... of the cells this far (cells, exclusive, inclusive) from the other side
MIN_SOLIDITY = 0.9  # a record that fills less of its convex hull gives no template: not a block (a part of an
# object, a handle, a lobed shape), whose outline says little about where the rest of a segment belongs


@dataclass(frozen=True)
class Template:
    """The target's outline: `cells` (h, w) bool, centred in a square crop wide enough to turn in, and the rotated
    copies (one per ANGLE_STEP_DEG) with the (row, col) offset of each copy's centroid in its crop."""

    cells: np.ndarray
    turned: tuple[tuple[np.ndarray, tuple[float, float]], ...]

    @classmethod
    def of(cls, mask: np.ndarray) -> Template | None:
        """The Template of the (H, W) bool `mask`; None when it holds fewer than MIN_TEMPLATE_CELLS cells or fills
        less than MIN_SOLIDITY of its convex hull (its largest outline's). Raises ValueError for an empty mask."""
        mask = np.asarray(mask, bool)
        rows, cols = np.nonzero(mask)
        if rows.size == 0:
            raise ValueError("a template needs a non-empty mask")
        if rows.size < MIN_TEMPLATE_CELLS:
            return None
        crop = mask[rows.min() : rows.max() + 1, cols.min() : cols.max() + 1]
        if solidity(crop) < MIN_SOLIDITY:
            return None
        side = int(np.ceil(np.hypot(*crop.shape))) + 2
        pad = np.zeros((side, side), np.uint8)
        r0, c0 = (side - crop.shape[0]) // 2, (side - crop.shape[1]) // 2
        pad[r0 : r0 + crop.shape[0], c0 : c0 + crop.shape[1]] = crop
        centre = ((side - 1) / 2.0, (side - 1) / 2.0)
        turned = []
        for angle in np.arange(0.0, 360.0, ANGLE_STEP_DEG):
            m = cv2.getRotationMatrix2D((centre[1], centre[0]), float(angle), 1.0)
            rot = cv2.warpAffine(pad * 255, m, (side, side), flags=cv2.INTER_LINEAR) > 127
            rr, cc = np.nonzero(rot)
            if rr.size:
                turned.append((rot, (float(rr.mean()), float(cc.mean()))))
        return cls(crop.copy(), tuple(turned))

    @property
    def area(self) -> int:
        return int(self.cells.sum())


def placements(segment: np.ndarray, template: Template) -> list[tuple[float, float, float, int, int, int]]:
    """Every placement of `template` in the (H, W) bool `segment` that FIT_MIN of its cells land on:
    (fit, centroid row, centroid col, turned index, top row, left col), best fit first."""
    segment = np.asarray(segment, bool)
    rows, cols = np.nonzero(segment)
    if rows.size == 0:
        return []
    side = template.turned[0][0].shape[0]
    r0, c0 = max(rows.min() - side, 0), max(cols.min() - side, 0)
    r1, c1 = min(rows.max() + side + 1, segment.shape[0]), min(cols.max() + side + 1, segment.shape[1])
    window = segment[r0:r1, c0:c1].astype(np.float32)
    if window.shape[0] < side or window.shape[1] < side:
        return []
    out = []
    for k, (rot, (cr, cc)) in enumerate(template.turned):
        n = float(rot.sum())
        hits = cv2.matchTemplate(window, rot.astype(np.float32), cv2.TM_CCORR) / n
        for tr, tc in zip(*np.nonzero(hits >= FIT_MIN), strict=True):
            out.append((float(hits[tr, tc]), r0 + tr + cr, c0 + tc + cc, k, int(r0 + tr), int(c0 + tc)))
    return sorted(out, key=lambda p: -p[0])


def cut(segment: np.ndarray, template: Template, expected: tuple[float, float],
        found: list[tuple[float, float, float, int, int, int]] | None = None) -> np.ndarray | None:
    """(H, W) bool: the cells of `segment` under the placement of `template` (dilated by one cell) whose centroid
    lies nearest `expected` (row, col), among those that fit (`found`: `placements(segment, template)`, computed
    when None); None when none fits."""
    found = placements(segment, template) if found is None else found
    if not found:
        return None
    best = min(found, key=lambda p: (np.hypot(p[1] - expected[0], p[2] - expected[1]), -p[0]))
    rot = template.turned[best[3]][0]
    placed = np.zeros(np.asarray(segment).shape, np.uint8)
    top, left = best[4], best[5]
    h = min(rot.shape[0], placed.shape[0] - top)
    w = min(rot.shape[1], placed.shape[1] - left)
    placed[top : top + h, left : left + w] = rot[:h, :w]
    placed = cv2.dilate(placed, np.ones((3, 3), np.uint8)) > 0
    return np.asarray(segment, bool) & placed


def look_alike_cut(segment: np.ndarray, template: Template, expected: tuple[float, float], predicted: np.ndarray,
                   found: list[tuple[float, float, float, int, int, int]]) -> np.ndarray | None:
    """`cut` of `segment` (placements `found`) when the segment meets the (H, W) bool `predicted` mask and the cut
    leaves a connected piece of REST_MIN times the template's area or more (module docstring); else None."""
    segment = np.asarray(segment, bool)
    if not found or not (segment & np.asarray(predicted, bool)).any():
        return None
    part = cut(segment, template, expected, found)
    if part is None:
        return None
    n, labels = cv2.connectedComponents((segment & ~part).astype(np.uint8), connectivity=8)
    sizes = np.bincount(labels.ravel(), minlength=n)[1:]
    return part if sizes.size and sizes.max() >= REST_MIN * template.area else None


def along_seam(hm: Heightmap, lab: np.ndarray, part: np.ndarray, rest: np.ndarray) -> bool:
    """Whether the (H, W) bool `part` and `rest` of one segment of `hm` (`lab`: its (H, W, 3) Lab image) meet along a
    seam (module docstring): their cells SEAM_BAND_CELLS from the line where they meet (the cells on the line may
    belong to either: a cut is placed to a cell) differ by SEAM_HEIGHT_M in median height or SEAM_COLOUR in median
    Lab colour. False where they do not meet."""
    part, rest = np.asarray(part, bool), np.asarray(rest, bool)
    lo, hi = SEAM_BAND_CELLS
    sides = []
    for mine, theirs in ((part, rest), (rest, part)):
        away = cv2.distanceTransform((~theirs).astype(np.uint8), cv2.DIST_L2, 3)
        sides.append(mine & (away > lo) & (away <= hi))
    if not sides[0].any() or not sides[1].any():
        return False
    height = np.asarray(hm.height)
    step = abs(float(np.median(height[sides[0]])) - float(np.median(height[sides[1]])))
    shade = float(np.linalg.norm(np.median(lab[sides[0]], axis=0) - np.median(lab[sides[1]], axis=0)))
    return step >= SEAM_HEIGHT_M or shade >= SEAM_COLOUR


def seam_cut(hm: Heightmap, lab: np.ndarray, segment: np.ndarray, template: Template,
             expected: tuple[float, float]) -> np.ndarray | None:
    """`look_alike_cut` of the (H, W) bool `segment` of `hm` (`lab`: its Lab image) nearest `expected` (row, col)
    where the cut runs `along_seam` with the rest of the segment; else None."""
    segment = np.asarray(segment, bool)
    found = placements(segment, template)
    part = look_alike_cut(segment, template, expected, segment, found) if found else None
    return part if part is not None and along_seam(hm, lab, part, segment & ~part) else None
