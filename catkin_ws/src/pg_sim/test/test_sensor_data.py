"""pg_sim.world.sensor_data: organised cloud layout (shape, dtype, NaN, colour packing), NaN depth, object marker
parts."""

from __future__ import annotations

import numpy as np
import pytest

from pg_core.geometry import load
from pg_sim.scenes.scene import ObjectSpec
from pg_sim.scenes.shapes import REGISTRY
from pg_sim.world.camera import depth_to_points
from pg_sim.world.sensor_data import (
    CLOUD_DTYPE,
    CLOUD_FIELDS,
    CloudBuilder,
    _prism_triangles,
    depth_with_nan,
    marker_parts,
    pose_parts,
    unpack_rgb,
)


@pytest.fixture(scope="module")
def camera():
    return load().camera


def test_cloud_layout_matches_pointcloud2_fields():
    assert CLOUD_DTYPE.itemsize == 16
    assert [(n, CLOUD_DTYPE.fields[n][1]) for n in CLOUD_DTYPE.names] == list(CLOUD_FIELDS)
    assert all(CLOUD_DTYPE.fields[n][0] == np.dtype("<f4") for n in CLOUD_DTYPE.names)


def test_organised_cloud_shape_nan_and_points(camera):
    rng = np.random.default_rng(0)
    h, w = camera.height, camera.width
    depth = rng.uniform(0.5, 0.8, (h, w)).astype(np.float32)
    depth[:10] = 0.0          # no return (sim camera convention)
    depth[20, 30] = np.nan    # no return (REP 118 convention)
    color = rng.integers(0, 256, (h, w, 3), dtype=np.uint8)
    cloud = CloudBuilder(camera.intrinsics, w, h).build(depth, color)
    assert cloud.shape == (480, 640) and cloud.dtype == CLOUD_DTYPE and cloud.nbytes == 640 * 480 * 16
    assert np.isnan(cloud["x"][:10]).all() and np.isnan(cloud["z"][:10]).all() and np.isnan(cloud["y"][20, 30])
    assert np.isfinite(cloud["z"][10:]).sum() == (h - 10) * w - 1
    ref = depth_to_points(np.nan_to_num(depth), camera.intrinsics).reshape(h, w, 3)
    got = np.stack([cloud["x"], cloud["y"], cloud["z"]], axis=-1)
    ok = np.isfinite(got[..., 2])
    np.testing.assert_allclose(got[ok], ref[ok], rtol=1e-5, atol=1e-6)
    np.testing.assert_array_equal(unpack_rgb(cloud["rgb"]), color)
    # PCL packing: 0x00RRGGBB in the float's bits
    assert cloud["rgb"][0, 0].view(np.uint32) == (int(color[0, 0, 0]) << 16) | (int(color[0, 0, 1]) << 8) | int(
        color[0, 0, 2])


def test_cloud_builder_rejects_wrong_sizes(camera):
    with pytest.raises(ValueError, match="do not match"):
        CloudBuilder(camera.intrinsics, camera.width, camera.height).build(np.zeros((10, 10)), np.zeros((10, 10, 3)))


def test_depth_with_nan():
    d = depth_with_nan(np.array([[0.0, 0.5], [-1.0, 0.7]]))
    assert d.dtype == np.float32
    assert np.isnan(d[0, 0]) and np.isnan(d[1, 0]) and d[0, 1] == np.float32(0.5)


@pytest.mark.parametrize("shape", sorted(REGISTRY))
def test_marker_parts_of_every_shape_stay_in_the_bounding_box(shape):
    spec = ObjectSpec(shape=shape, size=None, color=(89, 161, 79), pose=(0, 0, 0, 0, 0, 0))
    parts = marker_parts(spec)
    assert parts and all(p.kind in ("cube", "cylinder", "triangles") for p in parts)
    half = np.asarray(REGISTRY[shape].extents()) / 2 + 1e-6
    for part in parts:
        if part.kind == "triangles":
            assert part.points is not None and part.points.shape[0] % 3 == 0
        assert np.all(np.abs(part.position) <= half)


def test_prism_triangles_and_posing():
    tri = _prism_triangles(((0.0, 0.0), (1.0, 0.0), (0.0, 1.0)), 0.5)
    assert tri.shape == (3 * (2 + 2 * 3), 3)
    spec = ObjectSpec(shape="cube", size=None, color=(89, 161, 79), pose=(0, 0, 0, 0, 0, 0), name="c")
    (m,) = pose_parts("c", marker_parts(spec), np.array([0.1, 0.2, 0.3]), np.array([0, 0, np.sin(0.5), np.cos(0.5)]),
                      (1.0, 0.0, 0.0, 1.0))
    assert m.position == pytest.approx((0.1, 0.2, 0.3)) and m.part.scale == pytest.approx((0.045,) * 3)
    assert m.quaternion == pytest.approx((0, 0, np.sin(0.5), np.cos(0.5)))


def test_mesh_marker_is_offset_to_the_bounding_box_centre(tmp_path):
    obj = tmp_path / "box.obj"
    obj.write_text("v 0 0 0\nv 2 0 0\nv 0 4 0\nv 0 0 6\nf 1 2 3\nf 1 2 4\nf 1 3 4\nf 2 3 4\n")
    spec = ObjectSpec(shape="mesh", size=None, color=(89, 161, 79), pose=(0, 0, 0, 0, 0, 0), mesh=str(obj),
                      scale=(0.01, 0.01, 0.01))
    (part,) = marker_parts(spec)
    assert part.kind == "mesh" and part.mesh == str(obj)
    assert part.position == pytest.approx((-0.01, -0.02, -0.03))
