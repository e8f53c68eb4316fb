"""pg_policy.perception.view_change: cells that stayed, rose, were laid bare or changed colour between two views."""

from __future__ import annotations

import numpy as np

from pg_core.geometry import load
from pg_core.heightmap import Heightmap
from pg_policy.perception.segmentation import lab_image
from pg_policy.perception.view_change import view_change

GEO = load()


def _view(*blocks: tuple[int, int, float, tuple[int, int, int]]) -> Heightmap:
    """20 x 20-cell blocks: (row, col, height m, RGB) each, on a grey table."""
    height = np.zeros((224, 224), np.float32)
    colour = np.full((224, 224, 3), 200, np.uint8)
    for row, col, h, rgb in blocks:
        height[row : row + 20, col : col + 20], colour[row : row + 20, col : col + 20] = h, rgb
    return Heightmap(colour, height, np.ones((224, 224), bool), GEO.heightmap.resolution, GEO.workspace.bounds)


def test_a_block_that_stayed_one_put_on_another_and_one_repainted():
    red, blue = (200, 40, 40), (40, 60, 200)
    before = _view((20, 20, 0.03, red), (100, 100, 0.03, red), (150, 150, 0.03, red))
    after = _view((20, 20, 0.03, red), (100, 100, 0.06, blue), (150, 150, 0.03, blue))
    change = view_change(before, lab_image(before.color), after, lab_image(after.color))
    assert change.still[25, 25] and not change.still[105, 105] and not change.still[155, 155]
    assert change.arrived[105, 105] and not change.arrived[155, 155] and not change.arrived[25, 25]
    assert change.recoloured[155, 155] and change.recoloured[105, 105] and not change.recoloured[25, 25]
    back = view_change(after, lab_image(after.color), before, lab_image(before.color))
    assert back.uncovered[105, 105] and not back.uncovered[155, 155]
