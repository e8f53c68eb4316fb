"""Grasp heights (pg_core.action_geometry): DESIGN section 4's rule, and the low-object rule below 2 cm."""

from dataclasses import replace

import numpy as np
import pytest
import yaml

from pg_core import geometry
from pg_core.action_geometry import grasp_z, grasp_z_for_height

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


def _load(tmp_path, edit):
    raw = yaml.safe_load(geometry.DEFAULT_CONFIG.read_text())
    edit(raw["primitives"])
    path = tmp_path / "ws.yaml"
    path.write_text(yaml.safe_dump(raw))
    return geometry.load(path)


def test_low_keys_are_optional_and_off_when_absent(tmp_path):
    def drop(prims):
        for key in ("grasp_low_heights", "grasp_low_fraction", "grasp_low_min_z"):
            del prims[key]

    prims = _load(tmp_path, drop).primitives
    assert prims.grasp_low_heights == (0.0, 0.0)
    for h in (0.0, 0.003, 0.012, 0.045):
        assert grasp_z_for_height(h, prims) == section4(h)


@pytest.mark.parametrize("key, value", [("grasp_low_heights", [0.02, 0.002]), ("grasp_low_heights", [-0.001, 0.02]),
                                        ("grasp_low_heights", [0.002]), ("grasp_low_fraction", 1.5),
                                        ("grasp_low_fraction", "half"), ("grasp_low_min_z", -0.001)])
def test_malformed_low_keys_are_named(tmp_path, key, value):
    with pytest.raises(ValueError, match=f"primitives.{key}"):
        _load(tmp_path, lambda prims: prims.__setitem__(key, value))
