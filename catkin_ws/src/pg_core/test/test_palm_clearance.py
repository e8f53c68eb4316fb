"""The palm rule of the grasp height (pg_core.action_geometry.palm_clear_z, grasp_z with a yaw) on synthetic
heightmaps: the fingertips go no lower than keeps the palm clear of what lies under its footprint."""

import math
from dataclasses import replace

import numpy as np
import pytest

from pg_core import geometry
from pg_core.action_geometry import grasp_z, grasp_z_for_height, palm_clear_z

GEO = geometry.load()
PRIMS = GEO.primitives
OFF = replace(PRIMS, grasp_palm_clearance=None)
RES = 0.002


def _z(height, row, col, yaw, prims=PRIMS):
    return grasp_z(height, row, col, prims, yaw=yaw, resolution=RES)


def test_the_palm_comes_from_the_gripper_and_the_clearance_from_the_config():
    assert PRIMS.palm_footprint == GEO.gripper.palm_size[:2] == (0.11, 0.05)
    assert PRIMS.finger_length == GEO.gripper.finger_size[2] == 0.05
    assert PRIMS.grasp_palm_clearance == 0.005


def test_a_grasp_beside_a_taller_crest_rises_to_keep_the_palm_clear():
    # a lying bottle's flank: the cell 28 mm below a crest 12 mm away across the jaw; the section 4 rule would put the
    # fingertips 40 mm under the cell and the palm (50 mm above them) 18 mm into the crest
    height = np.zeros((100, 100))
    height[40:60, 40:70] = 0.08
    height[40:60, 56:62] = 0.108
    assert grasp_z_for_height(0.08, PRIMS) == pytest.approx(0.04)
    for yaw in (0.0, math.pi / 2, math.pi / 3):
        assert _z(height, 50, 50, yaw) == pytest.approx(0.108 - 0.05 + 0.005)
        assert _z(height, 50, 50, yaw, OFF) == pytest.approx(0.04)


def test_the_footprint_turns_with_the_jaw():
    # a tall post 40 mm from the grasp cell along x: under the palm (55 mm half-length) when the jaw closes along x,
    # clear of it (25 mm half-width) when it closes along y
    height = np.zeros((100, 100))
    height[48:53, 48:53] = 0.03
    height[49:52, 69:72] = 0.2
    assert _z(height, 50, 50, 0.0) == pytest.approx(0.2 - 0.05 + 0.005)
    assert _z(height, 50, 50, math.pi / 2) == pytest.approx(grasp_z_for_height(0.03, PRIMS))


def test_flat_tops_and_lone_objects_keep_the_cell_rule():
    height = np.zeros((100, 100))
    height[30:70, 30:70] = 0.045  # a block larger than the palm: fingertips 40 mm down, the palm 10 mm above it
    for yaw in np.linspace(0.0, math.pi, 8, endpoint=False):
        assert _z(height, 50, 50, yaw) == grasp_z_for_height(0.045, PRIMS)
    assert palm_clear_z(height, 50, 50, 0.0, RES, PRIMS) == pytest.approx(0.045 - 0.05 + 0.005)


def test_cells_beyond_the_map_are_left_out():
    height = np.full((20, 20), 0.1)
    assert palm_clear_z(height, 0, 0, 0.3, RES, PRIMS) == pytest.approx(0.1 - 0.05 + 0.005)
    assert palm_clear_z(np.zeros((5, 5)), 2, 2, 0.0, RES, OFF) is None


def test_absent_key_turns_the_rule_off(load_edited):
    absent = load_edited(lambda prims: prims.pop("grasp_palm_clearance")).primitives
    assert absent.grasp_palm_clearance is None
    assert absent.palm_footprint == (0.11, 0.05)  # still filled from the gripper
    height = np.zeros((100, 100))
    height[40:60, 40:70] = 0.08
    height[40:60, 56:62] = 0.108
    assert _z(height, 50, 50, 0.0, absent) == pytest.approx(0.04)


@pytest.mark.parametrize("value", [-0.01, "high", float("nan"), True])
def test_malformed_clearance_is_named(load_edited, value):
    with pytest.raises(ValueError, match="primitives.grasp_palm_clearance"):
        load_edited(lambda prims: prims.__setitem__("grasp_palm_clearance", value))


def test_a_push_starting_beside_a_tall_object_keeps_the_palm_above_it():
    # the push starts on the table 30 mm from a 120 mm box along the push: the section 4 rule lowers the fingertips to
    # push_min_z and the palm (50 mm above them) onto the box
    from pg_core.action_geometry import push_z

    height = np.zeros((100, 100))
    height[40:60, 65:80] = 0.12
    assert push_z(height, 50, 50, PRIMS) == PRIMS.push_min_z
    assert push_z(height, 50, 50, PRIMS, yaw=0.0, resolution=RES) == pytest.approx(0.12 - 0.05 + 0.005)
    assert push_z(height, 50, 50, PRIMS, yaw=math.pi / 2, resolution=RES) == PRIMS.push_min_z  # the palm across it
    assert push_z(height, 50, 50, OFF, yaw=0.0, resolution=RES) == PRIMS.push_min_z
    with pytest.raises(ValueError, match="resolution"):
        push_z(height, 50, 50, PRIMS, yaw=0.0)
