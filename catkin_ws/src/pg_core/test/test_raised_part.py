"""Raised parts along the jaw line (pg_core.action_geometry.raised_part and the grasp height it sets): the foot ring
of a bowl lying upside down, on synthetic heightmaps; round tops, blocks and objects on other objects keep the
cell rule."""

from dataclasses import replace

import numpy as np
import pytest

from pg_core import geometry
from pg_core.action_geometry import grasp_z, raised_part

PRIMS = replace(geometry.load().primitives, grasp_palm_clearance=None)  # the jaw-line rules alone
RES = 0.002
GREEN, BLUE, TABLE = (92, 168, 82), (78, 121, 167), (206, 185, 153)
FOOT_TOP = 0.053


def _scene(n: int = 140) -> tuple[np.ndarray, np.ndarray]:
    return np.zeros((n, n)), np.tile(np.array(TABLE, np.uint8), (n, n, 1))


def _radius(height: np.ndarray, rc: int, cc: int) -> np.ndarray:
    yy, xx = np.mgrid[:height.shape[0], :height.shape[1]]
    return np.hypot(yy - rc, xx - cc) * RES


def _upturned_bowl(height, color, rc, cc, radius=0.072, foot_r=0.03, foot_w=0.005, base=0.046,
                   foot=FOOT_TOP - 0.046):
    """A bowl upside down seen from above: a dome falling from `base` at the foot to the table at `radius`, the foot
    ring (`foot_w` wide, `foot` high) on top, its inside at `base`."""
    r = _radius(height, rc, cc)
    dome = base * (1.0 - ((r - foot_r) / (radius - foot_r)) ** 2)
    body = r <= radius
    height[body] = np.where(r <= foot_r, base, dome)[body]
    height[(r <= foot_r) & (r > foot_r - foot_w)] = base + foot
    color[body] = GREEN
    return height, color


def _z(height, color, row, col, yaw, prims=PRIMS):
    return grasp_z(height, row, col, prims, yaw=yaw, color=color, resolution=RES)


def test_part_keys_from_the_config():
    assert (PRIMS.grasp_part_step, PRIMS.grasp_part_clearance, PRIMS.grasp_part_contact) == (0.004, 0.002, 0.003)
    assert PRIMS.finger_thickness == geometry.load().gripper.finger_size[0]


@pytest.mark.parametrize("yaw", [0.0, 0.3927, 1.1781, 2.3562])
@pytest.mark.parametrize("offset", [(0, 0), (3, -2)])
def test_an_upturned_bowls_foot_is_grasped_with_the_fingers_just_above_the_bowl(yaw, offset):
    height, color = _upturned_bowl(*_scene(), 70, 70)
    row, col = 70 + offset[0], 70 + offset[1]
    part = raised_part(height, row, col, yaw, RES, PRIMS, color=color)
    assert part is not None
    assert part.top == pytest.approx(FOOT_TOP)
    assert 0.040 < part.fingers <= 0.046 + 1e-9  # the dome just outside the foot, under the open fingers
    z = _z(height, color, row, col, yaw)
    assert z == pytest.approx(part.fingers + PRIMS.grasp_part_clearance)
    assert z + PRIMS.grasp_part_contact <= FOOT_TOP  # the pads meet the foot's wall
    # without the rule the fingertips would go 40 mm below the foot, into the bowl
    assert _z(height, color, row, col, yaw, replace(PRIMS, grasp_part_step=0.0)) < 0.02


def test_a_foot_as_wide_as_the_open_jaw_or_too_low_is_no_part():
    wide, color = _upturned_bowl(*_scene(), 70, 70, radius=0.1, foot_r=0.044)
    assert raised_part(wide, 70, 70, 0.0, RES, PRIMS, color=color) is None
    low, color = _upturned_bowl(*_scene(), 70, 70, foot=0.004)
    assert raised_part(low, 70, 70, 0.0, RES, PRIMS, color=color) is None  # 4 mm: under clearance + contact


def test_round_tops_and_blocks_on_the_table_keep_the_cell_rule():
    height, color = _scene()
    yy, xx = np.mgrid[:140, :140]
    d = np.abs(xx - 70) * RES  # a cylinder 70 mm across lying along y
    height[d <= 0.035] = (0.035 + np.sqrt(np.maximum(0.035 ** 2 - d ** 2, 0.0)))[d <= 0.035]
    color[d <= 0.035] = GREEN
    for yaw in (0.0, 0.7854):
        assert raised_part(height, 70, 70, yaw, RES, PRIMS, color=color) is None
        assert _z(height, color, 70, 70, yaw) == grasp_z(height, 70, 70, PRIMS)
    block, color = _scene()
    block[60:80, 60:80] = 0.045
    color[60:80, 60:80] = GREEN
    assert raised_part(block, 70, 70, 0.0, RES, PRIMS, color=color) is None


def test_a_block_on_another_object_or_at_the_map_edge_is_no_part():
    height, color = _scene()
    height[40:100, 40:100], color[40:100, 40:100] = 0.03, BLUE  # a wide box of another colour
    height[62:78, 62:78], color[62:78, 62:78] = 0.06, GREEN  # a block on it
    assert raised_part(height, 70, 70, 0.0, RES, PRIMS, color=color) is None
    height, color = _upturned_bowl(*_scene(), 70, 125)
    assert raised_part(height, 70, 125, 0.0, RES, PRIMS, color=color) is None  # a finger beyond the map
    assert raised_part(height, 70, 125, 1.5708, RES, PRIMS, color=color) is not None  # along the edge: seen


def test_the_table_is_no_part_and_the_rule_is_off_without_the_keys(load_edited):
    height, color = _upturned_bowl(*_scene(), 70, 70)
    assert raised_part(height, 5, 5, 0.0, RES, PRIMS, color=color) is None

    def drop(prims):
        for key in ("grasp_part_step", "grasp_part_clearance", "grasp_part_contact"):
            del prims[key]

    absent = replace(load_edited(drop).primitives, grasp_palm_clearance=None)
    assert absent.grasp_part_step == 0.0
    assert raised_part(height, 70, 70, 0.0, RES, absent, color=color) is None


@pytest.mark.parametrize("key, value", [("grasp_part_step", -0.01), ("grasp_part_clearance", "high"),
                                        ("grasp_part_contact", float("inf"))])
def test_malformed_part_keys_are_named(load_edited, key, value):
    with pytest.raises(ValueError, match=f"primitives.{key}"):
        load_edited(lambda prims: prims.__setitem__(key, value))
