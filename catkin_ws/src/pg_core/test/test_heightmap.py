"""Reference heightmap projection: cell convention, explicit max, colour of the highest point, validity."""

import numpy as np
import pytest

from pg_core import heightmap as hm
from pg_core.geometry import load

BOUNDS = np.array([[-0.224, 0.224], [-0.224, 0.224], [0.0, 0.4]])
RES = 0.002


def test_cell_convention_and_shape():
    pts = np.array([[-0.224, -0.224, 0.01], [0.2235, -0.224, 0.02], [-0.224, 0.2235, 0.03]])
    cols = np.array([[255, 0, 0], [0, 255, 0], [0, 0, 255]], dtype=np.uint8)
    m = hm.project(pts, cols, BOUNDS, RES)
    assert m.height.shape == (224, 224) and m.color.shape == (224, 224, 3)
    assert m.height[0, 0] == pytest.approx(0.01)
    assert m.height[0, 223] == pytest.approx(0.02)  # x -> column
    assert m.height[223, 0] == pytest.approx(0.03)  # y -> row
    assert m.valid.sum() == 3 and m.height[~m.valid].max() == 0.0


def test_highest_point_wins_regardless_of_order():
    rng = np.random.default_rng(0)
    z = rng.uniform(0.0, 0.3, 500)
    pts = np.column_stack([np.full(500, 0.001), np.full(500, 0.001), z])
    cols = rng.integers(0, 255, (500, 3)).astype(np.uint8)
    top = int(np.argmax(z))
    for order in (np.arange(500), rng.permutation(500)):
        m = hm.project(pts[order], cols[order], BOUNDS, RES)
        r, c = hm.world_to_pixel(0.001, 0.001, BOUNDS, RES)
        assert m.height[r, c] == pytest.approx(z.max())
        assert tuple(m.color[r, c]) == tuple(cols[top])


def test_crop_and_clip():
    pts = np.array([[0.3, 0.0, 0.1], [0.0, 0.0, -0.05], [0.0, 0.1, 0.5], [np.nan, 0.0, 0.1]])
    m = hm.project(pts, np.zeros((4, 3), np.uint8), BOUNDS, RES)
    assert m.valid.sum() == 1  # only the below-table point survives (clipped to 0 height)
    assert m.height.max() == 0.0


def test_pixel_world_roundtrip():
    for r, c in [(0, 0), (10, 200), (223, 223), (111, 57)]:
        x, y = hm.pixel_to_world(r, c, BOUNDS, RES)
        assert hm.world_to_pixel(x, y, BOUNDS, RES) == (r, c)


def test_geometry_config_matches_design():
    g = load()
    assert (g.heightmap.rows, g.heightmap.cols) == (224, 224)
    assert g.heightmap.resolution == pytest.approx(0.002)
    np.testing.assert_allclose(g.workspace.bounds, BOUNDS)
    assert g.camera_frame == "camera_color_optical_frame"
