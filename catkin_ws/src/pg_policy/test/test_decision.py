"""Decision rule on analytic heightmaps and Q maps: masked argmax, threshold switch, regions, world pose, heights."""

import dataclasses
import math
from dataclasses import replace

import numpy as np
import pytest

from pg_core.geometry import load
from pg_core.heightmap import Heightmap
from pg_core.target_mask import TargetNotVisible
from pg_policy.decision.decision import (
    PUSH_RADIUS_M,
    Decision,
    action_pose,
    decide,
    grasp_region,
    masked_argmax,
    masked_max,
    push_region,
)

GEO = load()
PRIMS = GEO.primitives
RES = GEO.heightmap.resolution
H, W, R = GEO.heightmap.rows, GEO.heightmap.cols, GEO.heightmap.rotations
XMIN, YMIN = GEO.workspace.x[0], GEO.workspace.y[0]


def _hm(height=None, valid=None):
    height = np.zeros((H, W), np.float32) if height is None else height.astype(np.float32)
    valid = np.ones((H, W), bool) if valid is None else valid
    return Heightmap(np.zeros((H, W, 3), np.uint8), height, valid, RES, GEO.workspace.bounds)


def _target(r0=100, r1=120, c0=100, c1=120):
    m = np.zeros((H, W), bool)
    m[r0:r1, c0:c1] = True
    return m


def _q(*peaks, base=0.0):
    q = np.full((R, H, W), base, np.float32)
    for r, row, col, v in peaks:
        q[r, row, col] = v
    return q


def test_single_peak_grasp_pose():
    hm = _hm()
    hm.height[110, 115] = 0.07
    d = decide(_q((5, 110, 115, 2.0)), _q(), _target(), hm, PRIMS, grasp_threshold=1.0)
    assert (d.primitive, d.rotation, d.row, d.col) == ("grasp", 5, 110, 115)
    assert d.q == pytest.approx(2.0) and d.grasp_q == pytest.approx(2.0)
    assert d.yaw == pytest.approx(5 * 2 * math.pi / 16)
    assert d.x == pytest.approx(XMIN + 115.5 * RES) and d.y == pytest.approx(YMIN + 110.5 * RES)  # col -> x, row -> y
    assert d.z == pytest.approx(max(0.07 - PRIMS.grasp_depth, PRIMS.grasp_min_z))
    assert d.position == (d.x, d.y, d.z)
    with pytest.raises(dataclasses.FrozenInstanceError):
        d.row = 0


def test_target_mask_excludes_global_max():
    q = _q((3, 10, 10, 9.0), (7, 105, 118, 2.5), (2, 101, 101, 2.4))
    d = decide(q, _q(), _target(), _hm(), PRIMS, grasp_threshold=1.0)
    assert (d.rotation, d.row, d.col, d.q) == (7, 105, 118, pytest.approx(2.5))


def test_threshold_switches_grasp_and_push():
    qg = _q((0, 105, 105, 0.8))
    qp = _q((9, 95, 110, 1.5))  # 5 cells above the target: inside the push region
    target = _target()
    assert decide(qg, qp, target, _hm(), PRIMS, grasp_threshold=0.5).primitive == "grasp"
    push = decide(qg, qp, target, _hm(), PRIMS, grasp_threshold=1.0)
    assert (push.primitive, push.rotation, push.row, push.col) == ("push", 9, 95, 110)
    assert push.grasp_q == pytest.approx(0.8) and push.q == pytest.approx(1.5)
    equal = decide(qg, qp, target, _hm(), PRIMS, grasp_threshold=float(np.float32(0.8)))
    assert equal.primitive == "push"  # strictly greater is needed to grasp


def test_push_region_radius_and_override():
    target = _target()
    far = (4, 100, 100 + 20 + 40, 3.0)  # 40 cells = 0.08 m right of the target's last column (119)
    near = (6, 100, 119 + 20, 1.0)  # 20 cells = 0.04 m
    qp = _q(far, near)
    d = decide(_q(), qp, target, _hm(), PRIMS, grasp_threshold=1.0)
    assert (d.primitive, d.rotation, d.col) == ("push", 6, 139)
    assert decide(_q(), qp, target, _hm(), PRIMS, 1.0, push_radius_m=0.1).col == 160
    only = np.zeros((H, W), bool)
    only[200, 5] = True
    d = decide(_q(), qp, target, _hm(), PRIMS, 1.0, push_mask=only)
    assert (d.row, d.col) == (200, 5)


def test_regions():
    t = _target(100, 101, 100, 101)
    k = int(round(PUSH_RADIUS_M / RES))
    p = push_region(t, RES)
    assert p[100, 100 + k] and not p[100, 100 + k + 1] and p.sum() > 1
    assert p[100 + k, 100] and not p[100 + k, 100 + k]  # a disc, not a square
    assert np.array_equal(grasp_region(t, RES), t)
    assert grasp_region(t, RES, 0.004).sum() == 13  # radius 2 cells


def test_invalid_cells_are_never_chosen():
    valid = np.ones((H, W), bool)
    valid[105, 105] = False
    d = decide(_q((1, 105, 105, 5.0), (2, 106, 106, 3.0)), _q(), _target(), _hm(valid=valid), PRIMS, 1.0)
    assert (d.row, d.col, d.rotation) == (106, 106, 2)


def test_ties_go_to_first_in_c_order_and_nan_is_ignored():
    qg = _q(base=2.0)
    qg[0, 100, 100] = np.nan
    d = decide(qg, _q(), _target(), _hm(), PRIMS, 1.0)
    assert (d.rotation, d.row, d.col) == (0, 100, 101)
    assert masked_argmax(np.ones((3, 4, 4)), np.ones((4, 4), bool)) == (0, 0, 0, 1.0)


def test_world_pose_of_corners():
    hm = _hm()
    for row, col, x, y in [(0, 0, XMIN + RES / 2, YMIN + RES / 2), (H - 1, W - 1, -XMIN - RES / 2, -YMIN - RES / 2),
                           (0, W - 1, -XMIN - RES / 2, YMIN + RES / 2), (H - 1, 0, XMIN + RES / 2, -YMIN - RES / 2)]:
        px, py, _, _ = action_pose(hm, "grasp", 0, row, col, PRIMS)
        assert (px, py) == (pytest.approx(x), pytest.approx(y))
    mask = np.zeros((H, W), bool)
    mask[H - 1, 0] = True
    d = decide(_q((15, H - 1, 0, 3.0)), _q(), mask, hm, PRIMS, 1.0)
    assert (d.x, d.y, d.yaw) == (pytest.approx(XMIN + RES / 2), pytest.approx(-YMIN - RES / 2),
                                 pytest.approx(15 * math.pi / 8))


def test_push_height_from_local_max():
    no_palm = replace(PRIMS, grasp_palm_clearance=None)  # section 4's push height alone
    height = np.zeros((H, W))
    height[120, 100 + PRIMS.push_window_px] = 0.08  # inside the window
    height[120 - PRIMS.push_window_px - 1, 100] = 0.2  # just outside
    hm = _hm(height)
    assert action_pose(hm, "push", 0, 120, 100, no_palm)[2] == pytest.approx(0.08 - PRIMS.push_depth)
    assert action_pose(_hm(), "push", 0, 120, 100, PRIMS)[2] == pytest.approx(PRIMS.push_min_z)
    assert action_pose(_hm(), "grasp", 0, 120, 100, PRIMS)[2] == pytest.approx(PRIMS.grasp_min_z)
    d = decide(_q(), _q((0, 120, 100, 1.0)), _target(), hm, no_palm, 1.0)
    assert (d.primitive, d.z) == ("push", pytest.approx(0.07))
    # the palm rule: the 0.2 m post lies 12 mm across the push at rotation 0 (under the palm, 25 mm to each side);
    # at rotation 4 (pushing along +y) it lies 12 mm behind the start, under the palm's 55 mm too
    for rotation in (0, 4):
        assert action_pose(hm, "push", rotation, 120, 100, PRIMS)[2] == pytest.approx(
            0.2 - PRIMS.finger_length + PRIMS.grasp_palm_clearance)


def test_yaw_for_other_rotation_counts():
    hm = _hm()
    assert action_pose(hm, "push", 3, 0, 0, PRIMS, rotations=8)[3] == pytest.approx(3 * math.pi / 4)
    for r in range(16):
        assert action_pose(hm, "grasp", r, 0, 0, PRIMS)[3] == pytest.approx(math.radians(22.5 * r))


def test_errors():
    hm = _hm()
    with pytest.raises(TargetNotVisible):
        decide(_q(), _q(), np.zeros((H, W), bool), hm, PRIMS, 1.0)
    with pytest.raises(ValueError, match="q_push"):
        decide(_q(), np.zeros((R, H, W - 1)), _target(), hm, PRIMS, 1.0)
    with pytest.raises(ValueError, match="target mask"):
        decide(_q(), _q(), np.zeros((H - 1, W), bool), hm, PRIMS, 1.0)
    with pytest.raises(ValueError, match="unknown primitive"):
        action_pose(hm, "poke", 0, 0, 0, PRIMS)
    with pytest.raises(ValueError, match="rotation"):
        action_pose(hm, "grasp", 16, 0, 0, PRIMS)
    with pytest.raises(ValueError, match="outside"):
        action_pose(hm, "grasp", 0, H, 0, PRIMS)
    assert masked_max(_q(), np.zeros((H, W), bool)) == -math.inf
    with pytest.raises(ValueError):
        masked_argmax(_q(), np.zeros((H, W), bool))


def test_empty_grasp_region_pushes_with_minus_inf():
    d = decide(_q(), _q((1, 0, 0, 1.0)), _target(), _hm(), PRIMS, -10.0, grasp_mask=np.zeros((H, W), bool))
    assert isinstance(d, Decision) and d.primitive == "push" and d.grasp_q == -math.inf
