"""pg_policy.perception.push_shift: the displacement a push predicts for the object it meets."""

from __future__ import annotations

import math

import numpy as np
import pytest

from pg_core.heightmap import Heightmap
from pg_policy.perception.push_shift import push_shift


def _grid(n: int = 50, resolution: float = 0.002) -> Heightmap:
    """An empty n x n heightmap of `resolution` m cells with its lower corner at (0, 0) in `world`."""
    bounds = np.array([[0.0, n * resolution], [0.0, n * resolution], [0.0, 0.3]])
    return Heightmap(np.zeros((n, n, 3), np.uint8), np.zeros((n, n), np.float32), np.ones((n, n), bool), resolution,
                     bounds)


def test_push_shift_carries_the_object_in_the_corridor_to_the_pushs_end():
    hm = _grid(100)
    mask = np.zeros((100, 100), bool)
    mask[45:55, 40:50] = True  # x 0.080..0.100 m, y 0.090..0.110 m
    dx, dy = push_shift(mask, hm, 0.05, 0.1, 0.0, 0.13)  # along +x from 3 cm before its rear face
    assert dy == pytest.approx(0.0) and dx == pytest.approx(0.13 - 0.031, abs=1e-9)
    assert push_shift(mask, hm, 0.05, 0.2, 0.0, 0.13) == (0.0, 0.0)  # the corridor misses it
    assert push_shift(mask, hm, 0.05, 0.1, math.pi, 0.13) == (0.0, 0.0)  # pushes away from it
    dx, dy = push_shift(mask, hm, 0.09, 0.05, math.pi / 2, 0.13)  # along +y
    assert dx == pytest.approx(0.0, abs=1e-12) and dy == pytest.approx(0.13 - 0.041, abs=1e-9)
