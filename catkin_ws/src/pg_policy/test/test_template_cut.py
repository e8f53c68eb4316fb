"""pg_policy.perception.template_cut, and the tracker using it: a target lying in one segment with a look-alike of
its colour and height is cut out by its own outline, turned as it lies, at the place the push predicts; a target
that merely shows more of itself is not cut; small, empty or not block-like records give no template."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from pg_core.heightmap import Heightmap
from pg_policy.perception.target_tracker import TargetTracker
from pg_policy.perception.template_cut import Template, cut, look_alike_cut, placements

RES = 0.002  # m per cell


def _box(shape: tuple[int, int], r: int, c: int, h: int, w: int, angle: float = 0.0) -> np.ndarray:
    """(H, W) bool: an h x w box with top-left cell (r, c), turned by `angle` degrees about its centre."""
    m = np.zeros(shape, np.uint8)
    m[r : r + h, c : c + w] = 1
    if angle:
        rot = cv2.getRotationMatrix2D((c + (w - 1) / 2, r + (h - 1) / 2), angle, 1.0)
        m = cv2.warpAffine(m * 255, rot, (shape[1], shape[0])) // 128
    return m.astype(bool)


def _iou(a: np.ndarray, b: np.ndarray) -> float:
    return float((a & b).sum() / max((a | b).sum(), 1))


def _centroid(mask: np.ndarray) -> tuple[float, float]:
    rows, cols = np.nonzero(mask)
    return float(rows.mean()), float(cols.mean())


def test_a_record_too_small_gives_no_template_and_an_empty_one_is_refused():
    assert Template.of(_box((40, 40), 10, 10, 5, 5)) is None  # 25 cells: a sliver fits anywhere
    with pytest.raises(ValueError, match="non-empty"):
        Template.of(np.zeros((40, 40), bool))


def test_a_record_that_is_no_block_gives_no_template():
    ell = _box((60, 60), 10, 10, 30, 8) | _box((60, 60), 32, 10, 8, 30)  # an L: a handle, a part, not a block
    assert Template.of(ell) is None
    assert Template.of(_box((60, 60), 10, 10, 12, 30)) is not None


def test_two_bars_side_by_side_are_cut_at_the_one_nearest_the_expected_place():
    bar = _box((100, 100), 40, 20, 12, 30)
    other = _box((100, 100), 52, 20, 12, 30)  # the look-alike along the bar's long side: one segment
    template = Template.of(bar)
    assert template is not None
    segment = bar | other
    assert len(placements(segment, template)) >= 2
    for target, wrong in ((bar, other), (other, bar)):
        part = cut(segment, template, _centroid(target))
        assert part is not None and _iou(part, target) >= 0.85 and (part & wrong).sum() <= 30  # a row at most


def test_a_turned_target_against_a_cube_is_cut_by_its_turned_outline():
    template = Template.of(_box((100, 100), 10, 10, 12, 36))
    assert template is not None
    moved = _box((100, 100), 50, 30, 12, 36, angle=30.0)
    cube = _box((100, 100), 28, 50, 22, 22) & ~moved
    segment = moved | cube
    part = look_alike_cut(segment, template, _centroid(moved), moved, placements(segment, template))
    assert part is not None and _iou(part, moved) >= 0.8


def test_no_cut_away_from_the_predicted_place_or_of_a_target_that_shows_more_of_itself():
    template = Template.of(_box((100, 100), 10, 10, 12, 30))
    assert template is not None
    bar, other = _box((100, 100), 40, 20, 12, 30), _box((100, 100), 52, 20, 12, 30)
    segment = bar | other
    found = placements(segment, template)
    elsewhere = _box((100, 100), 80, 70, 10, 10)
    assert look_alike_cut(segment, template, _centroid(bar), elsewhere, found) is None  # not where it is expected
    larger = _box((100, 100), 40, 20, 16, 30)  # the target turned onto a larger face: no look-alike's worth left
    assert look_alike_cut(larger, template, _centroid(larger), larger, placements(larger, template)) is None


def _hm(height: np.ndarray, colour: tuple[int, int, int] = (200, 60, 60)) -> Heightmap:
    rgb = np.full(height.shape + (3,), 190, np.uint8)
    rgb[height > 0] = colour
    return Heightmap(rgb, height.astype(np.float32), np.ones(height.shape, bool), RES,
                     np.array([[0.0, height.shape[1] * RES], [0.0, height.shape[0] * RES], [0.0, 0.3]]))


def test_the_tracker_follows_a_target_pushed_against_a_look_alike():
    shape = (120, 120)
    target0 = _box(shape, 30, 20, 14, 34)
    other0 = _box(shape, 90, 70, 14, 34)  # a look-alike of its colour, height and shape elsewhere
    h0 = np.where(target0 | other0, 0.03, 0.0)
    tracker = TargetTracker()
    tracker.start(_hm(h0), target0)
    # a push of 6 cm along +y (rows) carries it, turned a little, against the long side of a look-alike that lay
    # beyond: one segment of both, whose form is no longer the target's
    target1 = _box(shape, 60, 20, 14, 34, angle=-5.0)
    other1 = _box(shape, 74, 32, 14, 34) & ~target1
    h1 = np.where(target1 | other1, 0.03, 0.0)
    track = tracker.update(_hm(h1), (0.0, 0.06))
    assert _iou(track.mask, target1) >= 0.8, track.why
    assert "cut to its shape" in track.why
