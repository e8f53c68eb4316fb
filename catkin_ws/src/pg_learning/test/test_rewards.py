"""Rewards on synthetic heightmap pairs: change around the target, occupancy ratio, push and grasp rewards."""

import math

import numpy as np
import pytest

from pg_core.heightmap import Heightmap
from pg_learning.training import rewards
from pg_policy.perception import scene_change

RES = 0.002
N = 224
BOUNDS = np.array([[-0.224, 0.224], [-0.224, 0.224], [0.0, 0.4]])
BLOCK = 0.045  # block height (m)
TARGET = (slice(100, 122), slice(100, 122))  # a 0.044 m square target


def _hm(*blocks, valid=None):
    h = np.zeros((N, N), np.float32)
    for (rs, cs), z in blocks:
        h[rs, cs] = z
    return Heightmap(np.zeros((N, N, 3), np.uint8), h, np.ones((N, N), bool) if valid is None else valid, RES, BOUNDS)


def _mask(sl):
    m = np.zeros((N, N), bool)
    m[sl] = True
    return m


NEIGHBOUR = (slice(100, 122), slice(123, 145))  # touching the target's right side (1 cell gap)
MOVED_AWAY = (slice(100, 122), slice(170, 192))
FAR = (slice(10, 40), slice(10, 40))


def test_grasp_reward():
    assert rewards.grasp_reward(True) == 1.0 and rewards.grasp_reward(False) == 0.0


def test_block_moved_away_is_a_change_and_frees_the_target():
    before = _hm((TARGET, BLOCK), (NEIGHBOUR, BLOCK))
    after = _hm((TARGET, BLOCK), (MOVED_AWAY, BLOCK))
    target = _mask(TARGET)
    n = scene_change.changed_cells(before, after, target)
    assert n == 22 * 4  # the neighbour's columns 123-126 lie within 5 cells (0.01 m) of the target's last (121)
    assert scene_change.scene_changed(before, after, target)
    occ_b = rewards.occupancy_ratio(before, target)
    occ_a = rewards.occupancy_ratio(after, target)
    assert occ_b > 0.15 and occ_a == 0.0
    assert rewards.push_reward(0.4, 1.2, True, occ_b, occ_a) == 0.5


def test_nothing_moved():
    before = _hm((TARGET, BLOCK), (NEIGHBOUR, BLOCK))
    target = _mask(TARGET)
    assert not scene_change.scene_changed(before, before, target)
    assert scene_change.changed_cells(before, before, target) == 0
    occ = rewards.occupancy_ratio(before, target)
    assert rewards.push_reward(0.4, 0.45, False, occ, occ) == -0.5
    assert rewards.push_reward(0.4, 1.5, False, occ, 0.0) == -0.5  # no change: bad push whatever Q_g says


def test_far_away_change_does_not_count():
    before = _hm((TARGET, BLOCK), (FAR, BLOCK))
    after = _hm((TARGET, BLOCK))
    target = _mask(TARGET)
    assert not scene_change.scene_changed(before, after, target)
    assert not scene_change.scene_changed(before, after, target, radius_m=0.05)
    assert scene_change.scene_changed(before, after, target, radius_m=0.2)  # 100 cells: the region reaches it


def test_thresholds_of_the_change():
    target = _mask(TARGET)
    before = _hm((TARGET, BLOCK), (NEIGHBOUR, BLOCK))
    shallow = _hm((TARGET, BLOCK), (NEIGHBOUR, BLOCK - 0.009))  # lowered by 9 mm < 1 cm
    assert not scene_change.scene_changed(before, shallow, target)
    assert scene_change.scene_changed(before, shallow, target, depth_thresh=0.005)
    few = _hm((TARGET, BLOCK), (NEIGHBOUR, BLOCK), ((slice(100, 105), slice(123, 130)), 0.0))  # 35 cells freed
    assert scene_change.changed_cells(before, few, target) == 20 and not scene_change.scene_changed(before, few, target)
    assert scene_change.scene_changed(before, few, target, min_cells=20)  # 5 rows x 4 columns in the region
    outlier = _hm((TARGET, BLOCK), (NEIGHBOUR, BLOCK + 0.5))  # e.g. the arm in view before: ignored
    assert not scene_change.scene_changed(outlier, before, target)


def test_increase_counts_only_when_asked():
    before = _hm((TARGET, BLOCK))
    after = _hm((TARGET, BLOCK), (NEIGHBOUR, BLOCK))  # a block pushed against the target
    target = _mask(TARGET)
    assert not scene_change.scene_changed(before, after, target)  # the authors' rule: heights must drop
    assert scene_change.scene_changed(before, after, target, decrease_only=False)


def test_target_moved_away_is_a_change():
    before = _hm((TARGET, BLOCK))
    after = _hm(((slice(100, 122), slice(150, 172)), BLOCK))
    assert scene_change.scene_changed(before, after, _mask(TARGET))


def test_invalid_cells_do_not_count():
    before = _hm((TARGET, BLOCK), (NEIGHBOUR, BLOCK))
    valid = np.ones((N, N), bool)
    valid[NEIGHBOUR] = False
    after = _hm((TARGET, BLOCK), valid=valid)
    assert not scene_change.scene_changed(before, after, _mask(TARGET))


def test_hull_covers_an_occluder_splitting_the_target():
    target = _mask(TARGET)
    target[:, 109:113] = False  # a thin object lies across the target
    before = _hm((TARGET, BLOCK), ((slice(90, 132), slice(109, 113)), BLOCK + 0.02))
    after = _hm((TARGET, BLOCK))
    hull = scene_change.convex_hull_mask(target)
    assert hull[TARGET].all() and hull.sum() == 22 * 22
    assert scene_change.changed_cells(before, after, target) == 4 * (22 + 2 * 5)
    assert scene_change.changed_cells(before, after, target, hull=False) < 4 * (22 + 2 * 5)


def test_occupancy_ratio():
    target = _mask(TARGET)
    ring = rewards.dilate_mask(target, RES, rewards.OCC_RADIUS_M) & ~target
    full = _hm(((slice(0, N), slice(0, N)), BLOCK))
    assert rewards.occupancy_ratio(full, target) == 1.0
    assert rewards.occupancy_ratio(_hm((TARGET, BLOCK)), target) == 0.0
    low = _hm(((slice(0, N), slice(0, N)), 0.01))  # below the 0.02 m occupancy height
    assert rewards.occupancy_ratio(low, target) == 0.0
    assert rewards.occupancy_ratio(low, target, 0.02, 0.005) == 1.0
    right = _hm((TARGET, BLOCK), ((slice(0, N), slice(122, N)), BLOCK))
    expected = (ring[:, 122:]).sum() / ring.sum()
    assert rewards.occupancy_ratio(right, target) == pytest.approx(expected)
    assert rewards.occupancy_ratio(full, np.zeros((N, N), bool)) == 0.0
    with pytest.raises(ValueError):
        rewards.occupancy_ratio(full, np.zeros((N, N - 1), bool))


@pytest.mark.parametrize(
    "qb, qa, changed, ob, oa, kwargs, expected",
    [
        (0.4, 0.6, True, 0.5, 0.2, {}, 0.5),
        (0.4, 0.5, True, 0.5, 0.2, {}, 0.0),  # gain 0.1 is not > 0.1
        (0.4, 0.9, True, 0.5, 0.45, {}, 0.0),  # occupancy barely dropped
        (0.4, 0.9, True, 0.5, 0.45, {"require_occupancy_drop": False}, 0.5),
        (0.4, 0.9, True, 0.5, 0.45, {"penalize_no_occupancy_drop": True}, -0.5),  # the authors' stricter rule
        (0.4, 0.9, True, 0.5, 0.2, {"penalize_no_occupancy_drop": True}, 0.5),
        (0.4, 0.9, False, 0.5, 0.2, {}, -0.5),
        (-math.inf, 0.9, True, 0.5, 0.2, {}, 0.5),  # target invisible before, graspable after
        (0.9, -math.inf, True, 0.5, 0.2, {}, 0.0),  # target lost: no gain
        (-math.inf, -math.inf, True, 0.5, 0.2, {}, 0.0),
        (0.4, 0.9, True, 0.5, 0.2, {"q_gain": 0.6}, 0.0),
    ],
)
def test_push_reward(qb, qa, changed, ob, oa, kwargs, expected):
    assert rewards.push_reward(qb, qa, changed, ob, oa, **kwargs) == expected


def test_shape_mismatch_raises():
    a = _hm()
    b = Heightmap(np.zeros((N, N - 1, 3), np.uint8), np.zeros((N, N - 1), np.float32), np.ones((N, N - 1), bool),
                  RES, BOUNDS)
    with pytest.raises(ValueError):
        scene_change.scene_changed(a, b, _mask(TARGET))
