"""pg_policy.perception.floors, through the segmentation: a dish's raised floor, parted from its wall by a groove, is
one object with the wall; an object lying in the dish, of another colour or as high as the wall, and look-alikes of
one height, stay apart."""

from __future__ import annotations

import numpy as np

from pg_core.geometry import load
from pg_core.heightmap import Heightmap
from pg_policy.perception.floors import join_floors
from pg_policy.perception.segmentation import segment_at, segment_objects

GEO = load()
GREY, RED = (150, 150, 150), (200, 40, 40)


def _disc(radius: float, centre: tuple[int, int] = (112, 112)) -> np.ndarray:
    rows, cols = np.mgrid[0:224, 0:224]
    return np.hypot(rows - centre[0], cols - centre[1]) <= radius


def _dish() -> tuple[Heightmap, np.ndarray]:
    """A grey dish: wall 3 cm high, 14 to 24 cells out; floor 1.5 cm high, 12 cells across; between them a 2-cell
    slit the camera does not see into. Returns the heightmap and the dish's cells."""
    height = np.zeros((224, 224), np.float32)
    colour = np.full((224, 224, 3), (205, 185, 150), np.uint8)
    valid = np.ones((224, 224), bool)
    wall, floor = _disc(24) & ~_disc(14), _disc(12)
    height[wall], colour[wall] = 0.03, GREY
    height[floor], colour[floor] = 0.015, GREY
    valid[_disc(14) & ~_disc(12)] = False
    colour[~valid] = 0
    return Heightmap(colour, height, valid, GEO.heightmap.resolution, GEO.workspace.bounds), wall | floor


def _iou(a: np.ndarray, b: np.ndarray) -> float:
    return float((a & b).sum() / max((a | b).sum(), 1))


def test_a_raised_floor_inside_its_wall_is_one_object_with_it():
    hm, dish = _dish()
    labels = segment_objects(hm)
    assert len(np.unique(labels[dish])) == 1 and labels[112, 112] > 0
    assert _iou(segment_at(hm, 112, 112), dish) >= 0.9  # a click at the middle names the dish


def _ring() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Labels of a ring (1) around a disc (2) on a 60 x 60 grid, both 4.5 cm high and one colour (Lab 0)."""
    rows, cols = np.mgrid[0:60, 0:60]
    r = np.hypot(rows - 30, cols - 30)
    labels = np.where(r <= 8, 2, np.where((r > 10) & (r <= 20), 1, 0)).astype(np.int32)
    return labels, np.where(labels > 0, 0.045, 0.0).astype(np.float32), np.zeros((60, 60, 3), np.float32)


def test_a_disc_in_a_ring_joins_it_only_lower_than_it_and_of_its_colour():
    labels, height, lab = _ring()
    assert np.array_equal(join_floors(labels, height, lab, 18.0), labels)  # as high: a look-alike in a ring of them
    height[labels == 2] = 0.02
    assert set(np.unique(join_floors(labels, height, lab, 18.0))) == {0, 1}  # lower, one colour: the floor
    lab[labels == 2] = (50.0, 60.0, 40.0)
    assert np.array_equal(join_floors(labels, height, lab, 18.0), labels)  # another colour: an object lying in it
    beside = labels.copy()
    beside[beside == 1] = 0
    beside[5:55, 5:12] = 1  # the other label beside it, not around it
    assert np.array_equal(join_floors(beside, np.where(beside == 1, 0.045, height), np.zeros_like(lab), 18.0), beside)
