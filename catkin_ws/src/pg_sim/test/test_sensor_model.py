"""Sensor models of the simulated camera (pg_sim.world.sensor_model): statistics of the table seen with `d435`, holes
along a box's depth edges, determinism per seed, `perfect` bit-identical to no model, and depth holes becoming
invalid heightmap cells."""

from __future__ import annotations

import math

import numpy as np
import pybullet as p
import pytest
from scipy.spatial.transform import Rotation

from pg_core import heightmap as hm
from pg_sim.world.camera import depth_to_points
from pg_sim.world.sensor_model import SimSensor, depth_edges, known_profiles, load_profile, make_sensor
from pg_sim.world.world import World

SEED = 7


@pytest.fixture(scope="module")
def d435():
    w = World(sensor="d435", sensor_seed=SEED)
    yield w
    w.close()


def _box(world: World, half: float = 0.03) -> int:
    col = p.createCollisionShape(p.GEOM_BOX, halfExtents=[half] * 3, physicsClientId=world.client)
    vis = p.createVisualShape(p.GEOM_BOX, halfExtents=[half] * 3, rgbaColor=[0, 1, 0, 1], physicsClientId=world.client)
    return p.createMultiBody(0, col, vis, basePosition=[0.05, -0.04, half], physicsClientId=world.client)


def test_profiles_and_unknown_names():
    assert known_profiles()[:1] == ["perfect"] and {"d435", "d415"} <= set(known_profiles())
    assert load_profile("perfect").perfect and make_sensor("perfect") is None
    d435, d415 = load_profile("d435"), load_profile("d415")
    assert (d435.baseline_m, d435.subpixel, d415.baseline_m, d415.subpixel) == (0.05, 0.08, 0.055, 0.05)
    assert d435.axial_sigma(0.7, 615.0) == pytest.approx(0.49 * 0.08 / (615.0 * 0.05))
    with pytest.raises(ValueError, match="known perfect, d415, d435"):
        load_profile("kinect")


def test_yaml_profile(tmp_path):
    path = tmp_path / "mine.yaml"
    path.write_text("baseline_m: 0.05\nsubpixel: 0.1\ndropout: 0.02\n")
    prof = load_profile(str(path))
    assert (prof.name, prof.subpixel, prof.dropout, prof.perfect) == ("mine", 0.1, 0.02, False)
    path.write_text("baseline: 0.05\n")
    with pytest.raises(ValueError, match="unknown key"):
        load_profile(str(path))
    path.write_text("dropout: 1.5\n")
    with pytest.raises(ValueError, match="out of range"):
        load_profile(str(path))


def test_table_plane_statistics(d435):
    """The bare table at 0.70 m: depth error std = the model's sigma (with the 1 mm step), 1 mm steps, 1 % holes."""
    cam = d435.camera
    cam.seed_sensor(SEED)
    clean = cam.render()
    sensed = cam.capture()
    prof = cam.sensor.profile
    assert np.all(clean.depth > 0.69) and np.all(clean.depth < 0.71)  # the table fills the view
    hit = sensed.depth > 0
    err = (sensed.depth - clean.depth)[hit].astype(np.float64)
    sigma = float(prof.axial_sigma(0.70, cam.spec.fx))
    assert sigma == pytest.approx(1.27e-3, abs=0.01e-3)
    expected = math.hypot(sigma, prof.quantisation_m / math.sqrt(12.0))
    assert err.std() == pytest.approx(expected, rel=0.1)
    assert abs(err.mean()) < 0.2 * sigma
    mm = sensed.depth[hit].astype(np.float64) * 1000.0
    assert np.abs(mm - np.round(mm)).max() < 1e-3  # 1 mm quantisation (float32 metres)
    assert np.diff(np.unique(np.round(mm))).min() == 1.0
    assert 0.008 < 1.0 - hit.mean() < 0.012  # 1 % dropout, no edges on the bare table


def test_correlated_part_is_smooth(d435):
    """Neighbouring pixels' errors correlate by about the correlated share of the variance."""
    cam = d435.camera
    clean, sensed = cam.render(), cam.capture()
    err = np.where((sensed.depth > 0), sensed.depth - clean.depth, np.nan).astype(np.float64)
    a, b = err[:, :-1].ravel(), err[:, 1:].ravel()
    ok = np.isfinite(a) & np.isfinite(b)
    r = np.corrcoef(a[ok], b[ok])[0, 1]
    assert 0.15 < r < 0.4  # 0.3 of sigma^2 correlated, less the quantisation's share


def test_holes_along_box_edges(d435):
    body = _box(d435)
    try:
        cam = d435.camera
        clean, sensed = cam.render(), cam.capture()
    finally:
        p.removeBody(body, physicsClientId=d435.client)
    edges = depth_edges(clean.depth, 0.01, 2)
    assert 400 < edges.sum() < 2000  # a band around the box's outline
    assert np.all(sensed.depth[edges] == 0)  # no return along the depth edges
    hole = sensed.depth[~edges] == 0
    assert 0.008 < hole.mean() < 0.012  # elsewhere: the 1 % dropout
    box = clean.segmentation == body
    assert np.any(box & (sensed.depth > 0))  # the box's top is seen


def test_pose_error_and_determinism():
    sensor = SimSensor(load_profile("d435"), seed=SEED)
    err = sensor.pose_error
    assert np.linalg.norm(err[:3, 3]) == pytest.approx(0.003)
    assert np.degrees(np.linalg.norm(Rotation.from_matrix(err[:3, :3]).as_rotvec())) == pytest.approx(0.3)
    with World(sensor="d435", sensor_seed=SEED) as a, World(sensor="d435", sensor_seed=SEED) as b:
        assert np.array_equal(a.camera.render_pose, b.camera.render_pose)
        assert not np.allclose(a.camera.render_pose, a.camera.pose, atol=1e-4)
        fa, fb = a.capture(), b.capture()
        assert np.array_equal(fa.depth, fb.depth) and np.array_equal(fa.color, fb.color)
        b.camera.seed_sensor(SEED + 1)
        fb2 = b.capture()
        assert not np.array_equal(fa.depth, fb2.depth)
        assert not np.array_equal(a.camera.render_pose, b.camera.render_pose)
        a.camera.seed_sensor(SEED + 1)
        assert np.array_equal(a.capture().depth, fb2.depth)


def test_perfect_is_bit_identical_to_no_model():
    with World() as plain, World(sensor="perfect", sensor_seed=SEED) as perfect:
        assert perfect.camera.sensor is None and perfect.camera.render_pose is perfect.camera.pose
        perfect.camera.seed_sensor(3)  # nothing to seed
        _box(plain)
        _box(perfect)
        a, b = plain.observe(), perfect.observe()
        assert np.array_equal(a.frame.depth, b.frame.depth) and np.array_equal(a.frame.color, b.frame.color)
        assert np.array_equal(a.frame.depth, plain.camera.render().depth)
        for field in ("height", "color", "valid"):
            assert np.array_equal(getattr(a.heightmap, field), getattr(b.heightmap, field))


def test_depth_hole_becomes_invalid_cells():
    """Holes (0 or NaN depth) in a depth image of the table are invalid cells, not table (the C++ projector:
    test_heightmap_projector.cpp, HolesAreInvalidCells, on the same frame)."""
    width, height, f, z = 64, 48, 100.0, 0.5
    k = np.array([[f, 0.0, (width - 1) / 2], [0.0, f, (height - 1) / 2], [0.0, 0.0, 1.0]])
    depth = np.full((height, width), z, dtype=np.float32)
    depth[10:20, 20:30] = 0.0
    depth[30:40, 40:50] = np.nan
    pose = np.eye(4)
    pose[:3, :3] = np.diag([1.0, -1.0, -1.0])  # looking down from z = 0.5 at a table at z = 0
    pose[2, 3] = z
    bounds = np.array([[-0.16, 0.16], [-0.12, 0.12], [-0.01, 0.3]])
    heightmap = hm.project(hm.transform_points(depth_to_points(depth, k), pose), np.zeros((width * height, 3)),
                           bounds, 0.01)
    # pixel (u, v) sees world x = (u - cx) z / f, y = -(v - cy) z / f: cells of 1 cm, 5 mm per pixel
    col = lambda u: int(np.floor(((u - k[0, 2]) * z / f + 0.16) / 0.01))  # noqa: E731
    row = lambda v: int(np.floor((-(v - k[1, 2]) * z / f + 0.12) / 0.01))  # noqa: E731
    assert not heightmap.valid[row(12), col(22)] and not heightmap.valid[row(35), col(45)]
    assert heightmap.valid[row(25), col(10)]
    assert heightmap.valid.sum() == heightmap.valid.size - 2 * 25  # 10 x 10 px holes: 5 x 5 cells each
    assert np.all(heightmap.height[~heightmap.valid] == 0) and np.all(heightmap.color[~heightmap.valid] == 0)
