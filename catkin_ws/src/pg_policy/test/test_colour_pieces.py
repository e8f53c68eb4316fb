"""pg_policy.perception.colour_pieces: a thin object of another colour lying along a wider one, too thin for a seed of
its own, is split from the wider one's segment; one object whose colour drifts without an edge (shading) stays
whole; the input labels are not changed."""

from __future__ import annotations

import numpy as np

from pg_core.geometry import load
from pg_core.heightmap import Heightmap
from pg_policy.perception.colour_pieces import split_colours
from pg_policy.perception.segmentation import (
    COLOUR_EDGE,
    MIN_OBJECT_CELLS,
    _colour_strength,
    lab_image,
    segment_objects,
)

GEO = load()
RED, BLUE = (200, 40, 40), (40, 60, 200)


def _heightmap(height: np.ndarray, colour: np.ndarray) -> Heightmap:
    return Heightmap(colour, height, np.ones(height.shape, bool), GEO.heightmap.resolution, GEO.workspace.bounds)


def _bar_and_rod() -> tuple[Heightmap, np.ndarray, np.ndarray]:
    """A red bar 20 x 60 cells, 2 cm tall, and a blue rod 3 x 50 cells, 2 cm tall, lying against its side."""
    height = np.zeros((224, 224), np.float32)
    colour = np.full((224, 224, 3), 200, np.uint8)
    bar = np.zeros((224, 224), bool)
    bar[80:100, 80:140] = True
    rod = np.zeros((224, 224), bool)
    rod[100:103, 85:135] = True
    height[bar | rod] = 0.02
    colour[bar], colour[rod] = RED, BLUE
    return _heightmap(height, colour), bar, rod


def test_a_thin_rod_of_another_colour_along_a_bar_is_its_own_segment():
    hm, bar, rod = _bar_and_rod()
    labels = segment_objects(hm)
    rod_label = np.bincount(labels[rod]).argmax()
    assert rod_label and (labels == rod_label).sum() <= 1.2 * rod.sum(), "the rod is split from the bar"
    assert not (labels[bar] == rod_label).any()
    assert np.bincount(labels[bar]).argmax() != rod_label


def test_without_the_split_the_rod_shares_the_bar_segment():
    """What the split is for: the watershed alone floods the seedless rod from the bar's seed."""
    hm, bar, rod = _bar_and_rod()
    merged = (np.asarray(hm.height) > 0).astype(np.int32)
    lab = lab_image(hm.color)
    strength = _colour_strength(lab)
    before = merged.copy()
    out = split_colours(merged, lab[..., 1:], strength, COLOUR_EDGE, MIN_OBJECT_CELLS)
    assert np.array_equal(merged, before), "the input is not changed"
    assert len(np.unique(out[rod])) == 1 and out[rod][0] != out[bar][0]


def test_shading_without_an_edge_stays_one_segment():
    """A disc whose colour drifts smoothly from red to orange across it (chroma apart by more than a colour edge
    end to end, never by an edge between neighbours) is one object."""
    height = np.zeros((224, 224), np.float32)
    colour = np.full((224, 224, 3), 200, np.uint8)
    rows, cols = np.mgrid[:224, :224]
    disc = (rows - 112) ** 2 + (cols - 112) ** 2 <= 30**2
    height[disc] = 0.03
    green = np.clip(40 + (cols - 82) * 2.5, 40, 190).astype(np.uint8)  # red to orange, a small step per cell
    colour[disc] = np.stack([np.full_like(green, 210), green, np.full_like(green, 40)], axis=-1)[disc]
    labels = segment_objects(_heightmap(height, colour))
    assert len(np.unique(labels[disc])) == 1 and labels[disc][0] > 0
