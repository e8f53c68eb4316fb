"""pg_policy.perception.segment_scores: segments scored against a target's record at its predicted place; another
colour or a segment beyond the gate is not scored, a merged look-alike is cut to the predicted place or, where the
target's outline fits, to that outline."""

from __future__ import annotations

import numpy as np

from pg_core.heightmap import Heightmap
from pg_policy.perception.segment_scores import SegmentScorer
from pg_policy.perception.segmentation import lab_image, segment_objects
from pg_policy.perception.target_appearance import describe
from pg_policy.perception.template_cut import Template

RES = 0.002
SHAPE = (120, 120)


def _hm(boxes: list[tuple[int, int, int, int, tuple[int, int, int]]]) -> Heightmap:
    height = np.zeros(SHAPE, np.float32)
    rgb = np.full(SHAPE + (3,), 190, np.uint8)
    for r, c, h, w, colour in boxes:
        height[r : r + h, c : c + w] = 0.03
        rgb[r : r + h, c : c + w] = colour
    return Heightmap(rgb, height, np.ones(SHAPE, bool), RES, np.array([[0.0, 0.24], [0.0, 0.24], [0.0, 0.3]]))


def _mask(r: int, c: int, h: int, w: int) -> np.ndarray:
    m = np.zeros(SHAPE, bool)
    m[r : r + h, c : c + w] = True
    return m


def _scorer(first: Heightmap, mask: np.ndarray) -> SegmentScorer:
    return SegmentScorer(describe(first, mask), Template.of(mask), RES)


def _score(scorer: SegmentScorer, hm: Heightmap, predicted: np.ndarray, gate: float = 30.0) -> list:
    rows, cols = np.nonzero(predicted)
    place = (predicted, (float(rows.mean()), float(cols.mean())))
    return scorer.score(hm, segment_objects(hm), lab_image(hm.color), np.zeros(SHAPE, bool), [place], gate)


def test_the_target_at_its_place_scores_best_and_another_colour_or_a_far_segment_not_at_all():
    red, blue = (200, 50, 50), (40, 80, 200)
    target = _mask(20, 20, 14, 30)
    scorer = _scorer(_hm([(20, 20, 14, 30, red)]), target)
    view = _hm([(40, 20, 14, 30, red), (40, 60, 14, 30, blue), (100, 90, 14, 20, red)])
    scored = _score(scorer, view, _mask(40, 20, 14, 30))
    assert scored and scored[0][0] > 0.9 and scored[0][3][45, 30] and scored[0][4] == ""
    assert all(not s[3][45, 70] for s in scored)  # the blue one: under the colour floor
    assert all(not s[3][105, 95] for s in scored)  # the far red one: beyond the gate


def test_a_look_alike_sharing_the_segment_is_cut_off_by_the_outline():
    red = (200, 50, 50)
    target = _mask(20, 20, 14, 34)
    scorer = _scorer(_hm([(20, 20, 14, 34, red)]), target)
    view = _hm([(50, 20, 14, 34, red), (64, 32, 14, 34, red)])  # touching along the long side: one segment
    scored = _score(scorer, view, _mask(50, 20, 14, 34))
    best = scored[0][3]
    assert scored[0][4] == "shaped"
    truth = _mask(50, 20, 14, 34)
    assert (best & truth).sum() / (best | truth).sum() >= 0.85
