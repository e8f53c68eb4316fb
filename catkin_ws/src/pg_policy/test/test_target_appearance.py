"""pg_policy.perception.target_appearance: the CIE94 colour difference and the partly covered test."""

from __future__ import annotations

import numpy as np
import pytest

from pg_core.geometry import load
from pg_core.heightmap import Heightmap
from pg_policy.perception.target_appearance import delta_e94, describe, partly_covered

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
