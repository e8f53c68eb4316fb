"""pg_policy.perception.segmentation, step 6: the pieces of one long object (a rod seen on both sides of an object
lying across it, a bar bent over something) are one object; a look-alike beyond the cover that does not continue
the rod, and a rod whose gap shows the table, stay apart."""

from __future__ import annotations

import numpy as np
import pytest

from pg_core.heightmap import Heightmap
from pg_policy.perception.long_pieces import JOIN_GAP_M
from pg_policy.perception.segmentation import segment_at, segment_objects

RES = 0.002  # m per cell
BLUE, RED = (40, 90, 200), (220, 40, 40)


def _table() -> tuple[np.ndarray, np.ndarray]:
    return np.zeros((120, 160), np.float32), np.full((120, 160, 3), 200, np.uint8)


def _hm(height: np.ndarray, colour: np.ndarray) -> Heightmap:
    bounds = np.array([[0.0, 160 * RES], [0.0, 120 * RES], [0.0, 0.3]])
    return Heightmap(colour, height, np.ones_like(height, bool), RES, bounds)


def _rod_under_block() -> tuple[np.ndarray, np.ndarray]:
    """A blue rod 1.2 cm wide and 24 cm long (rows 57-62, cols 20-139) at 8 mm under a red 4 x 4 cm block 3 cm
    high across its middle (cols 70-89)."""
    height, colour = _table()
    height[57:63, 20:140], colour[57:63, 20:140] = 0.008, BLUE
    height[50:70, 70:90], colour[50:70, 70:90] = 0.03, RED
    return height, colour


def test_a_rod_seen_on_both_sides_of_an_object_across_it_is_one_object():
    hm = _hm(*_rod_under_block())
    rod = segment_at(hm, 60, 40)
    assert rod[60, 40] and rod[60, 120], "the piece beyond the block belongs to the clicked rod"
    assert not rod[55, 80], "the block lying across it does not"
    assert rod.sum() == 2 * 6 * 50


def test_a_gap_that_shows_the_table_keeps_the_pieces_apart():
    height, colour = _rod_under_block()
    height[57:63, 70:76], colour[57:63, 70:76] = 0.0, 200  # the rod's pieces end 6 cells short of the block
    rod = segment_at(_hm(height, colour), 60, 40)
    assert rod[60, 40] and not rod[60, 120]


def test_a_look_alike_beyond_the_cover_that_does_not_continue_the_rod_stays_apart():
    height, colour = _table()
    height[57:63, 20:70], colour[57:63, 20:70] = 0.008, BLUE  # the rod, ending under the block ...
    height[50:70, 70:90], colour[50:70, 70:90] = 0.03, RED
    height[45:75, 90:120], colour[45:75, 90:120] = 0.008, BLUE  # ... a wide blue slab beyond it
    height[20:26, 90:140], colour[20:26, 90:140] = 0.008, BLUE  # a blue rod beside the block, off the axis
    hm = _hm(height, colour)
    rod = segment_at(hm, 60, 40)
    assert rod[60, 40] and not rod[60, 100] and not rod[22, 100]
    assert segment_objects(hm).max() == 4


def test_a_gap_longer_than_an_object_lying_across_stays_apart():
    wide = int(round(JOIN_GAP_M / RES)) + 5
    height, colour = _table()
    height[57:63, 5:155], colour[57:63, 5:155] = 0.008, BLUE
    height[40:80, 30:30 + wide], colour[40:80, 30:30 + wide] = 0.03, RED
    rod = segment_at(_hm(height, colour), 60, 15)
    assert rod[60, 15] and not rod[60, 150]


@pytest.mark.parametrize("step_m, joined", [(0.007, True), (0.02, False)], ids=["bent", "another-level"])
def test_a_long_bar_split_by_a_step_is_one_object_up_to_a_centimetre(step_m, joined):
    """A blue bar 1.2 x 24 cm whose right half lies `step_m` higher (on something thin): the step is a depth edge
    between two long pieces end to end; a bar a step higher than JOIN_HEIGHT_M is another object."""
    height, colour = _table()
    height[57:63, 20:80], colour[57:63, 20:140] = 0.008, BLUE
    height[57:63, 80:140] = 0.008 + step_m
    hm = _hm(height, colour)
    labels = segment_objects(hm)
    assert labels[60, 40] > 0 and labels[60, 120] > 0
    assert (labels[60, 40] == labels[60, 120]) == joined


def test_touching_blocks_of_one_colour_and_two_heights_stay_apart():
    height, colour = _table()
    height[50:65, 50:65], height[50:65, 65:80] = 0.03, 0.037  # two 3 cm cubes, 7 mm apart in height
    colour[50:65, 50:80] = BLUE
    labels = segment_objects(_hm(height, colour))
    assert labels[57, 55] != labels[57, 75]
