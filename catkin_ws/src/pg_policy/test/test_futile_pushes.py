"""pg_policy.decision.rules.futile_pushes: which pushes count as futile and which Q values a remembered one
suppresses."""

from __future__ import annotations

import numpy as np
import pytest

from pg_core.geometry import load
from pg_core.heightmap import Heightmap, pixel_to_world
from pg_policy.decision.rules.futile_pushes import FutilePushes

G = load()
N = G.heightmap.rows


def _hm(height: np.ndarray | None = None) -> Heightmap:
    h = np.zeros((N, N), np.float32) if height is None else height
    return Heightmap(np.zeros((N, N, 3), np.uint8), h, np.ones((N, N), bool), G.heightmap.resolution,
                     G.workspace.bounds)


def _block(rows: slice, cols: slice, z: float = 0.04) -> np.ndarray:
    h = np.zeros((N, N), np.float32)
    h[rows, cols] = z
    return h


def test_a_push_that_changed_nothing_near_the_target_is_remembered():
    target = np.zeros((N, N), bool)
    target[100:110, 100:110] = True
    before = _hm(_block(slice(100, 110), slice(112, 125)))  # a neighbour right of the target
    mem = FutilePushes(16)
    assert mem.observe_push(5, 0.0, 0.0, before, _hm(before.height.copy()), target)  # nothing moved
    assert mem.pushes == [(5, 0.0, 0.0)]
    moved = _hm(_block(slice(100, 110), slice(150, 163)))  # the neighbour was pushed 7.6 cm away
    assert not mem.observe_push(6, 0.1, 0.1, before, moved, target) and len(mem.pushes) == 1
    far = _hm(before.height.copy())
    far.height[0:10, 0:10] = 0.05  # an object appeared far from the target
    assert mem.observe_push(7, 0.0, 0.0, _hm(before.height.copy()), far, target)  # a change far away does not count
    mem.clear()
    assert mem.pushes == []


def test_suppresses_only_the_push_direction_near_the_futile_push():
    hm, q = _hm(), np.random.default_rng(0).random((16, N, N))
    mem = FutilePushes(16, radius_m=0.01)
    assert mem.suppress(q, hm) is q
    x, y = pixel_to_world(100, 80, hm.bounds, hm.resolution)
    mem.pushes.append((3, x, y))
    out = mem.suppress(q, hm)
    assert np.isneginf(out[3, 100, 80]) and np.isneginf(out[3, 104, 80]) and np.isfinite(out[3, 106, 80])
    assert np.isfinite(out[11, 100, 80])  # the opposite direction is another push
    assert np.isfinite(np.delete(out, 3, axis=0)).all() and np.isfinite(q).all()


def test_zero_radius_is_off_and_negative_is_refused():
    hm, q = _hm(), np.ones((16, N, N))
    mem = FutilePushes(16, radius_m=0.0)
    mem.pushes.append((0, 0.0, 0.0))
    assert mem.suppress(q, hm) is q
    with pytest.raises(ValueError, match="radius"):
        FutilePushes(16, radius_m=-0.01)
