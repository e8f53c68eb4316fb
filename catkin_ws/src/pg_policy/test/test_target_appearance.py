"""pg_policy.perception.target_appearance: the CIE94 colour difference, the partly covered test and the terms that
score a segment against the target's record."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from pg_core.geometry import load
from pg_core.heightmap import Heightmap
from pg_policy.perception.target_appearance import (
    UNKNOWN_TERM,
    delta_e94,
    describe,
    match_terms,
    partly_covered,
    shifted,
)

GEO = load()


def _block(height: float = 0.03) -> Heightmap:
    """A 4 x 4 cm red block, `height` m tall, at cells (100..119, 100..119) of a 224 x 224 grid."""
    heights = np.zeros((224, 224), np.float32)
    colour = np.full((224, 224, 3), 200, np.uint8)
    heights[100:120, 100:120], colour[100:120, 100:120] = height, (200, 40, 40)
    return Heightmap(colour, heights, np.ones((224, 224), bool), GEO.heightmap.resolution, GEO.workspace.bounds)


def test_delta_e94_is_cie94_and_weighs_hue_over_shading():
    # Sharma, Wu and Dalal's first test pair, CIE94 graphic arts: 1.3950
    assert delta_e94(np.array([50, 2.6772, -79.7751]), np.array([50, 0, -82.7485]), k_l=1.0) == pytest.approx(
        1.3950, abs=1e-4)
    red, shaded, orange = np.array([47.3, 51.7, 28.8]), np.array([61.0, 62.6, 34.8]), np.array([60.0, 40.0, 60.0])
    assert delta_e94(red, shaded) < 0.5 * delta_e94(red, orange)  # a tilted red face is nearer red than orange


def test_partly_covered_is_a_border_that_stands_higher_than_the_mask():
    covered = _block()
    covered.height[96:124, 104:130] = 0.05  # a higher block over all but a strip of the red one
    strip = np.zeros((224, 224), bool)
    strip[100:120, 100:104] = True
    assert partly_covered(covered, strip)
    alone = np.zeros((224, 224), bool)
    alone[100:120, 100:120] = True
    assert not partly_covered(_block(), alone)


def test_describe_measures_area_heights_shape_and_place():
    mask = np.zeros((224, 224), bool)
    mask[100:120, 100:120] = True
    seen = describe(_block(0.03), mask)
    assert seen.area == 400 and seen.height == pytest.approx(0.03) and seen.top == pytest.approx(0.03)
    assert seen.ratio == pytest.approx(1.0) and seen.centroid == pytest.approx((109.5, 109.5))
    assert not seen.partial


def test_match_terms_score_the_same_block_one_and_fall_with_distance_size_and_colour():
    hm = _block()
    mask = np.zeros((224, 224), bool)
    mask[100:120, 100:120] = True
    ref = describe(hm, mask)
    res = GEO.heightmap.resolution
    assert match_terms(ref, ref, mask, mask, ref.centroid, res) == pytest.approx((1.0, 1.0, 1.0, 1.0))
    moved = shifted(mask, 0, 25)  # the block 5 cm away: no overlap, nearness exp(-1)
    there = Heightmap(np.roll(hm.color, 25, axis=1), np.roll(hm.height, 25, axis=1), hm.valid, res, hm.bounds)
    colour, form, overlap, near = match_terms(ref, describe(there, moved), moved, mask, ref.centroid, res)
    assert (colour, form, overlap) == pytest.approx((1.0, 1.0, 0.0)) and near == pytest.approx(np.exp(-1), abs=0.01)
    half = mask.copy()
    half[:, 110:] = False
    assert match_terms(ref, describe(hm, half), half, mask, ref.centroid, res)[1] < 0.9  # half the area, a 2:1 form
    other = _block()
    other.color[100:120, 100:120] = (40, 60, 200)
    assert match_terms(ref, describe(other, mask), mask, mask, ref.centroid, res)[0] < 0.1  # blue against red
    partial = replace(describe(hm, half), partial=True)  # a record of a partly covered target: a larger segment's
    form = match_terms(partial, ref, mask, mask, ref.centroid, res)[1]  # area and shape terms say nothing
    assert form == pytest.approx((1.0 + 2 * UNKNOWN_TERM) / 3, abs=0.01)
