"""Simulated camera: intrinsics consistent with the images, metric depth, cloud and heightmap in `world`."""

import numpy as np
import pybullet as p
import pytest

from pg_core import heightmap as hm
from pg_sim.world.camera import project_points
from pg_sim.world.world import World


@pytest.fixture(scope="module")
def world():
    w = World()
    yield w
    w.close()


def _marker(world, xyz, half=0.004):
    col = p.createCollisionShape(p.GEOM_BOX, halfExtents=[half] * 3, physicsClientId=world.client)
    vis = p.createVisualShape(p.GEOM_BOX, halfExtents=[half] * 3, rgbaColor=[1, 0, 0, 1], physicsClientId=world.client)
    return p.createMultiBody(0, col, vis, basePosition=xyz, physicsClientId=world.client)


def test_known_points_land_on_predicted_pixels(world):
    rng = np.random.default_rng(3)
    ws = world.geometry.workspace
    markers = []
    for _ in range(12):
        xyz = [rng.uniform(ws.x[0] + 0.02, ws.x[1] - 0.02), rng.uniform(ws.y[0] + 0.02, ws.y[1] - 0.02),
               rng.uniform(0.01, 0.2)]
        markers.append((_marker(world, xyz), np.array(xyz)))
    frame = world.capture()
    cam = world.camera
    world_to_cam = np.linalg.inv(cam.pose)
    for body, xyz in markers:
        top = xyz + [0, 0, 0.004]  # centre of the marker's top face
        pc = world_to_cam[:3, :3] @ top + world_to_cam[:3, 3]
        u, v = project_points(pc, cam.intrinsics)[0]
        ui, vi = int(round(u)), int(round(v))
        assert frame.segmentation[vi, ui] == body, (xyz, u, v)
        assert frame.depth[vi, ui] == pytest.approx(pc[2], abs=2e-3)
    for body, _ in markers:
        p.removeBody(body, physicsClientId=world.client)


def test_cloud_and_heightmap_are_metric(world):
    body = _marker(world, [0.05, -0.08, 0.1], half=0.02)
    obs = world.observe()
    r, c = hm.world_to_pixel(0.05, -0.08, obs.heightmap.bounds, obs.heightmap.resolution)
    assert obs.heightmap.height[r, c] == pytest.approx(0.12, abs=2e-3)
    assert obs.heightmap.valid.mean() > 0.99  # the table fills the workspace
    assert np.median(obs.heightmap.height[obs.heightmap.height < 0.01]) == pytest.approx(0.0, abs=1e-3)
    p.removeBody(body, physicsClientId=world.client)


def test_images_follow_realsense_conventions(world):
    frame = world.capture()
    s = world.geometry.camera
    assert frame.color.shape == (s.height, s.width, 3) and frame.color.dtype == np.uint8
    assert frame.depth.shape == (s.height, s.width) and frame.depth.dtype == np.float32
    # looking straight down from 0.7 m: the image centre sees the table at ~0.7 m
    assert frame.depth[s.height // 2, s.width // 2] == pytest.approx(s.xyz[2], abs=2e-3)
