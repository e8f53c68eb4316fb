"""Grasp heights (pg_core.action_geometry): DESIGN section 4's rule, the low-object rule below 2 cm, and pits along
the jaw line (bowls, cups, plates) on synthetic heightmaps."""

import math
from dataclasses import replace

import numpy as np
import pytest

from pg_core import geometry
from pg_core.action_geometry import grasp_z, grasp_z_for_height, rim_pit

PRIMS = geometry.load().primitives
OFF = replace(PRIMS, grasp_low_heights=(0.0, 0.0))  # DESIGN section 4 everywhere


def section4(h: float) -> float:
    return max(h - PRIMS.grasp_depth, PRIMS.grasp_min_z)


def test_config_values():
    assert PRIMS.grasp_low_heights == (0.002, 0.02)
    assert PRIMS.grasp_low_fraction == 0.35
    assert PRIMS.grasp_low_min_z == 0.0015


@pytest.mark.parametrize("h", [0.02, 0.0201, 0.0225, 0.025, 0.045, 0.0459, 0.052, 0.06, 0.09, 0.2, 0.4])
def test_objects_from_2_cm_keep_the_section_4_rule_exactly(h):
    # blocks (45 mm cubes, a half cube lying: 22.5 mm), household objects: the value and its float bits unchanged
    assert grasp_z_for_height(h, PRIMS) == section4(h) == grasp_z_for_height(h, OFF)


@pytest.mark.parametrize("h", [0.0, 0.0005, 0.0019])
def test_empty_cells_keep_the_section_4_rule(h):
    assert grasp_z_for_height(h, PRIMS) == PRIMS.grasp_min_z


@pytest.mark.parametrize("h", np.arange(0.002, 0.02, 0.0005))
def test_low_objects_close_below_their_widest_part_above_the_table(h):
    z = grasp_z_for_height(float(h), PRIMS)
    assert z == pytest.approx(max(0.35 * h, 0.0015))
    assert 0.0015 <= z < PRIMS.grasp_min_z
    assert z <= 0.35 * h or z == 0.0015
    if h >= 0.004:  # pens lying down (8 mm and up) and spheres are widest at h / 2: the pads reach below it
        assert z < h / 2
    assert h - z >= 0.0005  # the pads overlap the object


def test_thin_pen_and_small_examples():
    assert grasp_z_for_height(0.003, PRIMS) == pytest.approx(0.0015)  # a 3 mm card: fingertips 1.5 mm up
    assert grasp_z_for_height(0.005, PRIMS) == pytest.approx(0.00175)  # a 5 mm knife blade
    assert grasp_z_for_height(0.012, PRIMS) == pytest.approx(0.0042)  # a 12 mm pen, widest at 6 mm
    assert grasp_z_for_height(0.019, PRIMS) == pytest.approx(0.00665)  # a 19 mm part
    assert grasp_z_for_height(0.005, OFF) == PRIMS.grasp_min_z  # the old rule closed 12 mm up, above them


def test_grasp_z_reads_the_pixel_and_zmin():
    height = np.zeros((4, 5))
    height[1, 2], height[2, 3] = 0.01, 0.045
    assert grasp_z(height, 1, 2, PRIMS) == pytest.approx(0.0035)
    assert grasp_z(height, 2, 3, PRIMS) == section4(0.045)
    assert grasp_z(height, 0, 0, PRIMS) == PRIMS.grasp_min_z
    assert grasp_z(height, 1, 2, PRIMS, zmin=0.03) == section4(0.04)


def test_low_keys_are_optional_and_off_when_absent(load_edited):
    def drop(prims):
        for key in ("grasp_low_heights", "grasp_low_fraction", "grasp_low_min_z"):
            del prims[key]

    prims = load_edited(drop).primitives
    assert prims.grasp_low_heights == (0.0, 0.0)
    for h in (0.0, 0.003, 0.012, 0.045):
        assert grasp_z_for_height(h, prims) == section4(h)


@pytest.mark.parametrize("key, value", [("grasp_low_heights", [0.02, 0.002]), ("grasp_low_heights", [-0.001, 0.02]),
                                        ("grasp_low_heights", [0.002]), ("grasp_low_fraction", 1.5),
                                        ("grasp_low_fraction", "half"), ("grasp_low_min_z", -0.001)])
def test_malformed_low_keys_are_named(load_edited, key, value):
    with pytest.raises(ValueError, match=f"primitives.{key}"):
        load_edited(lambda prims: prims.__setitem__(key, value))


# -- pits along the jaw line (grasp_z with a yaw) --------------------------------------------------------------------

RES = 0.002
GREEN, BLUE, RED, TABLE = (92, 168, 82), (78, 121, 167), (255, 87, 87), (206, 185, 153)


def _scene(n: int = 140) -> tuple[np.ndarray, np.ndarray]:
    """An empty table: (n, n) heights and table-coloured (n, n, 3) colours."""
    return np.zeros((n, n)), np.tile(np.array(TABLE, np.uint8), (n, n, 1))


def _bowl(height, color, rc, cc, radius=0.055, rim=0.05, floor=0.009, floor_r=0.03, wall=0.004, shade=1.0):
    """A bowl seen from above: a flat floor, an inner wall rising to the rim, a rim `wall` m wide at `rim` m."""
    yy, xx = np.mgrid[:height.shape[0], :height.shape[1]]
    r = np.hypot(yy - rc, xx - cc) * RES
    inner = np.clip((r - floor_r) / (radius - wall - floor_r), 0.0, 1.0)
    bowl = r <= radius
    height[bowl] = (floor + (rim - floor) * inner ** 2)[bowl]
    height[bowl & (r > radius - wall)] = rim
    color[bowl] = (np.array(GREEN) * np.where(r[bowl, None] < radius - wall, shade, 1.0)).astype(np.uint8)
    return height, color


PIT = replace(PRIMS, grasp_palm_clearance=None)  # the jaw-line pit rule alone (the palm rule: test_palm_clearance.py)


def _z(height, color, row, col, yaw, prims=PIT):
    return grasp_z(height, row, col, prims, yaw=yaw, color=color, resolution=RES)


def test_rim_keys_from_the_config():
    assert (PRIMS.grasp_rim_depth, PRIMS.grasp_rim_clearance, PRIMS.grasp_rim_step, PRIMS.grasp_rim_wall,
            PRIMS.grasp_rim_reach) == (0.03, 0.005, 0.01, 0.012, 0.0425)


@pytest.mark.parametrize("yaw", [0.0, math.pi, math.pi / 8, -math.pi / 8])
def test_a_bowl_floor_next_to_the_wall_grasps_below_the_rim_above_the_floor(yaw):
    height, color = _bowl(*_scene(), 70, 70, shade=0.6)  # the inner wall in shade: same chromaticity
    row, col = 70, 70 - 14  # on the floor, 28 mm from the axis, 23 mm inside the rim's inner edge
    old = grasp_z(height, row, col, PRIMS)
    assert old == pytest.approx(0.35 * 0.009)  # the cell alone: 3 mm up, the bowl's bottom
    z = _z(height, color, row, col, yaw)
    assert z == pytest.approx(0.05 - PRIMS.grasp_rim_depth)  # 3 cm below the rim, 11 mm above the floor
    assert 0.009 + PRIMS.grasp_rim_clearance <= z < 0.05
    pit = rim_pit(height, row, col, yaw, RES, PRIMS, color=color)
    assert pit is not None and pit.floor == pytest.approx(0.009) and pit.rim == pytest.approx(0.05)
    wr, wc = pit.wall  # the nearer wall's cell: on the line, towards -x (the wall 23 mm from the cell), high up
    assert wr == row + round((wc - col) * math.tan(yaw)) and wc < col - 5 and height[wr, wc] >= 0.05 - 0.005


def test_a_shallow_pit_keeps_the_fingertips_above_the_floor():
    height, color = _bowl(*_scene(), 70, 70, rim=0.022, floor=0.008)  # a plate's well and rim
    z = _z(height, color, 70, 70 - 14, 0.0)
    assert z == pytest.approx(0.008 + PRIMS.grasp_rim_clearance)  # rim - depth would be under the floor


def test_a_cup_between_two_walls_takes_the_lower_rim():
    height, color = _scene()
    yy, xx = np.mgrid[:140, :140]
    r = np.hypot(yy - 70, xx - 70) * RES
    cup = r <= 0.039
    height[cup], color[cup] = 0.006, BLUE
    height[cup & (r > 0.035) & (xx < 70)] = 0.09
    height[cup & (r > 0.035) & (xx >= 70)] = 0.08  # a slightly tilted rim: one side lower
    assert _z(height, color, 70, 70, 0.0) == pytest.approx(0.08 - PRIMS.grasp_rim_depth)
    assert grasp_z(height, 70, 70, PRIMS) == pytest.approx(0.35 * 0.006)


def test_the_wall_must_be_in_reach_and_across_the_jaw():
    height, color = _bowl(*_scene(), 70, 70, radius=0.1, floor_r=0.08)  # a wide bowl: flat floor 8 cm around
    assert _z(height, color, 70, 70, 0.0) == grasp_z(height, 70, 70, PRIMS)  # its centre: no wall within 42.5 mm
    row, col = 70, 70 - 35  # 70 mm from the axis: the rim 26-30 mm away along x, 100 mm along y
    assert _z(height, color, row, col, 0.0) == pytest.approx(0.05 - PRIMS.grasp_rim_depth)
    assert _z(height, color, row, col, math.pi / 2) == grasp_z(height, row, col, PRIMS)


def test_the_table_between_two_blocks_keeps_the_cell_rule():
    height, color = _scene()
    height[60:80, 40:62], color[60:80, 40:62] = 0.045, GREEN
    height[60:80, 78:100], color[60:80, 78:100] = 0.045, GREEN  # same colour, 32 mm apart
    for col in (66, 70, 74):
        assert _z(height, color, 70, col, 0.0) == grasp_z(height, 70, col, PRIMS) == PRIMS.grasp_min_z
        assert _z(height, None, 70, col, 0.0) == PRIMS.grasp_min_z


def test_block_tops_edges_and_flanks_keep_the_cell_rule():
    height, color = _scene()
    height[60:80, 60:82], color[60:80, 60:82] = 0.045, GREEN  # a 45 mm block, 44 mm wide
    height[60:80, 59], color[60:80, 59] = 0.02, GREEN  # its side face seen at the edge: a 20 mm cell
    height[60:80, 82:92], color[60:80, 82:92] = 0.0225, GREEN  # a half cube of the same colour against it
    for yaw in np.arange(8) * math.pi / 8:
        for col in (59, 62, 70, 80, 85, 90):
            assert _z(height, color, 70, col, yaw) == grasp_z(height, 70, col, PRIMS), (col, yaw)
    roof, roof_color = _scene()  # a triangular prism lying on a face: a 40 mm ridge along y, flanks down to the table
    for dc in range(-10, 11):
        roof[50:90, 70 + dc], roof_color[50:90, 70 + dc] = 0.04 - 0.004 * abs(dc), GREEN
    for col in (62, 64, 66):
        assert _z(roof, roof_color, 70, col, 0.0) == grasp_z(roof, 70, col, PRIMS)


def test_edge_cells_leaning_blocks_and_gaps_between_objects_keep_the_cell_rule():
    height, color = _scene()
    height[60:80, 50:72], color[60:80, 50:72] = 0.045, GREEN  # a block and a same-coloured one touching it,
    height[60:80, 72], color[60:80, 72] = 0.024, GREEN  # with an edge cell between them seen half-way down
    height[60:80, 73:76], color[60:80, 73:76] = 0.041, GREEN  # and a 6 mm sliver of the other block, then table
    assert _z(height, color, 70, 72, 0.0) == grasp_z(height, 70, 72, PRIMS)
    ramp, ramp_color = _scene()  # a block leaning on another: its top climbs 24 mm in 24 mm, then its edge
    for k in range(13):
        ramp[60:80, 60 + k], ramp_color[60:80, 60 + k] = 0.02 + 0.002 * k, GREEN
    ramp[60:80, 73:75], ramp_color[60:80, 73:75] = 0.045, GREEN
    ramp[60:80, 40:60], ramp_color[60:80, 40:60] = 0.03, BLUE  # what it leans on
    for col in (62, 64, 66):
        assert _z(ramp, ramp_color, 70, col, 0.0) == grasp_z(ramp, 70, col, PRIMS), col
    gap, gap_color = _scene()  # a low green part beside a thin green wall, a tall blue box on the other side
    gap[60:80, 60:70], gap_color[60:80, 60:70] = 0.02, GREEN
    gap[60:80, 70:72], gap_color[60:80, 70:72] = 0.06, GREEN
    gap[60:80, 40:60], gap_color[60:80, 40:60] = 0.09, BLUE
    assert _z(gap, gap_color, 70, 62, 0.0) == grasp_z(gap, 70, 62, PRIMS)


def test_a_long_leaning_block_keeps_the_cell_rule_and_a_bowls_inner_wall_does_not():
    ramp, color = _scene()  # a 100 mm block leaning: its top rises 1 mm per cell to its upper edge at 61 mm
    for k in range(50):
        ramp[60:80, 30 + k], color[60:80, 30 + k] = 0.012 + 0.001 * k, GREEN
    for col in (60, 64, 68):  # the upper edge within reach: a "wall"; the far side falls away on the same block
        assert _z(ramp, color, 70, col, 0.0) == grasp_z(ramp, 70, col, PRIMS), col
    height, color = _bowl(*_scene(), 70, 70, radius=0.09, floor_r=0.03, rim=0.07)  # a big bowl, inner wall curving
    col = 70 - 37  # 74 mm from the axis: on the inner wall, the rim 12 mm further out, the floor 30 mm further in
    assert height[70, col] > 0.03
    assert _z(height, color, 70, col, 0.0) == pytest.approx(max(0.07 - PRIMS.grasp_rim_depth,
                                                               float(height[70, col]) + PRIMS.grasp_rim_clearance))
    assert grasp_z(height, 70, col, PRIMS) == PRIMS.grasp_min_z  # the cell alone: fingertips 12 mm up


def test_a_thin_object_on_the_table_keeps_the_low_object_rule():
    height, color = _scene()
    height[60:80, 40:100], color[60:80, 40:100] = 0.0025, GREEN  # a knife blade lying
    height[64:76, 100:120], color[64:76, 100:120] = 0.012, GREEN  # its handle
    for col in (60, 90, 98):
        for yaw in (0.0, math.pi / 2):
            assert _z(height, color, 70, col, yaw) == grasp_z(height, 70, col, PRIMS) == pytest.approx(0.0015)


def test_another_object_in_the_bowl_keeps_its_own_height():
    height, color = _bowl(*_scene(), 70, 70)
    height[66:74, 40:60], color[66:74, 40:60] = 0.015, RED  # a red spoon handle lying on the floor by the wall
    assert _z(height, color, 70, 50, 0.0) == grasp_z(height, 70, 50, PRIMS) == pytest.approx(0.35 * 0.015)
    assert _z(height, color, 70, 84, 0.0) == pytest.approx(0.05 - PRIMS.grasp_rim_depth)  # the floor across the bowl
    assert _z(height, color, 70, 62, 0.0) == grasp_z(height, 70, 62, PRIMS)  # its one wall is behind the spoon


def test_a_mug_handle_keeps_the_cell_rule():
    height, color = _scene()
    yy, xx = np.mgrid[:140, :140]
    r = np.hypot(yy - 70, xx - 70) * RES
    mug = r <= 0.04
    height[mug], color[mug] = 0.006, GREEN
    height[mug & (r > 0.036)] = 0.09
    height[66:74, 90:104], color[66:74, 90:104] = 0.07, GREEN  # the handle, 20 mm below the rim, out along +x
    for yaw in (0.0, math.pi / 2):  # radially (the rim 12 mm away, the table beyond the handle) and across
        assert _z(height, color, 70, 98, yaw) == grasp_z(height, 70, 98, PRIMS) == pytest.approx(0.07 - 0.04)


def test_the_jaw_line_needs_the_resolution_and_is_off_without_the_keys(load_edited):
    height, color = _bowl(*_scene(), 70, 70)
    with pytest.raises(ValueError, match="resolution"):
        grasp_z(height, 70, 56, PRIMS, yaw=0.0)
    off = replace(PIT, grasp_rim_step=0.0)
    assert _z(height, color, 70, 56, 0.0, off) == grasp_z(height, 70, 56, PRIMS)

    def drop(prims):
        for key in ("grasp_rim_depth", "grasp_rim_clearance", "grasp_rim_step", "grasp_rim_wall", "grasp_rim_reach"):
            del prims[key]

    absent = replace(load_edited(drop).primitives, grasp_palm_clearance=None)
    assert absent.grasp_rim_step == 0.0 and absent.grasp_rim_reach == 0.0
    assert _z(height, color, 70, 56, 0.0, absent) == grasp_z(height, 70, 56, PRIMS)


@pytest.mark.parametrize("key, value", [("grasp_rim_depth", -0.01), ("grasp_rim_step", "high"),
                                        ("grasp_rim_reach", float("nan")), ("grasp_rim_wall", True)])
def test_malformed_rim_keys_are_named(load_edited, key, value):
    with pytest.raises(ValueError, match=f"primitives.{key}"):
        load_edited(lambda prims: prims.__setitem__(key, value))


def test_grasp_z_at_reads_the_heightmap():
    from pg_core.action_geometry import grasp_z_at
    from pg_core.heightmap import Heightmap

    height, color = _bowl(*_scene(), 70, 70)
    bounds = np.array([[-0.14, 0.14], [-0.14, 0.14], [0.0, 0.4]])
    hm = Heightmap(color=color, height=height.astype(np.float32), valid=np.ones_like(height, bool), resolution=RES,
                   bounds=bounds)
    assert grasp_z_at(hm, 70, 56, PRIMS) == pytest.approx(grasp_z(height, 70, 56, PRIMS))
    assert grasp_z_at(hm, 70, 56, PRIMS, yaw=0.0) == pytest.approx(_z(height, color, 70, 56, 0.0), abs=1e-6)
