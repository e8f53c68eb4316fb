"""Grasps of concave household objects in PyBullet: the grasp height of a pit along the jaw line.

A bowl wider than the open jaw lies alone on the table. A grasp on its floor next to the wall, closing across the
wall (radially), straddles the wall: with the grasp height of the cell alone (the floor: fingertips a few mm up) the
inner finger goes to the bottom of the bowl and the jaw closes on air; with the jaw-line rule
(pg_core.action_geometry.grasp_z with the grasp's yaw) the fingertips go below the rim and above the floor, and the
bowl is lifted. The probe (pg_sim.world.grasp_probe) measures the same over many objects and cells.
"""

from __future__ import annotations

import math

import pytest
from scipy.spatial.transform import Rotation

from pg_core import heightmap as hm
from pg_core.action_geometry import grasp_z, grasp_z_at, rim_pit
from pg_sim.objects.catalog import household_info, object_spec
from pg_sim.scenes.scene import SceneSpec
from pg_sim.world.grasp_probe import RULES, candidates, run, table
from pg_sim.world.primitives import PrimitiveExecutor
from pg_sim.world.world import World

BOWL = "bowl/1"  # 127 mm across, 42 mm high: wider than the jaw (85 mm)
INSIDE_M = 0.026  # the grasp cell lies this far inside the bowl's outline: on its floor, next to the wall


@pytest.fixture(scope="module")
def world():
    w = World()
    yield w
    w.close()


def _scene() -> SceneSpec:
    info = household_info(BOWL)
    rot = Rotation.from_euler("xyz", info.rest_rpy)
    spec = object_spec(BOWL, (89, 161, 79), (0.0, 0.0, info.extents[2] / 2 + 0.002, *rot.as_euler("xyz")), "bowl",
                       target=True)
    return SceneSpec("bowl", "green", (spec,), family="test")


@pytest.mark.parametrize("side", [1.0, -1.0])
def test_a_wall_grasp_lifts_a_bowl_wider_than_the_jaw_and_the_cell_height_does_not(world, side):
    info = household_info(BOWL)
    prims = world.geometry.primitives
    assert info.extents[0] > world.geometry.gripper.max_opening
    world.load_scene(_scene())
    obs = world.observe().heightmap
    x = side * (info.extents[0] / 2 - INSIDE_M)
    row, col = hm.world_to_pixel(x, 0.0, obs.bounds, obs.resolution)
    yaw = 0.0  # rotation 0: the fingers close along x, across the wall
    pit = rim_pit(obs.height, row, col, yaw, obs.resolution, prims, color=obs.color)
    assert pit is not None and pit.rim - pit.floor > 0.02  # the cell is the bowl's floor, the rim 2+ cm above it
    z_new = grasp_z_at(obs, row, col, prims, yaw=yaw)
    z_old = grasp_z(obs.height, row, col, prims)
    assert pit.floor + prims.grasp_rim_clearance <= z_new < pit.rim
    assert z_old < pit.floor  # the cell alone: the fingertips at the bottom of the bowl
    cx, cy = hm.pixel_to_world(row, col, obs.bounds, obs.resolution)
    new = PrimitiveExecutor(world).grasp(cx, cy, z_new, yaw)
    assert new.target_grasped, new
    world.load_scene(_scene())
    old = PrimitiveExecutor(world).grasp(cx, cy, z_old, yaw)
    assert not old.target_grasped, old


def test_the_jaw_line_leaves_the_bowl_rim_and_other_cells_to_the_cell_rule(world):
    world.load_scene(_scene())
    obs = world.observe().heightmap
    mask = world.label_heightmap(world.capture()) == world.target_id
    cands = candidates("bowl", obs, mask, world.geometry.heightmap.rotations, angles=4)
    assert {c.region for c in cands} == {"rim", "wall", "deep"}
    prims = world.geometry.primitives
    for c in cands:
        yaw = hm.rotation_yaw(c.rotation, world.geometry.heightmap.rotations)
        if c.region == "rim":  # on the rim: its own height decides
            assert grasp_z_at(obs, c.row, c.col, prims, yaw=yaw) == pytest.approx(grasp_z(obs.height, c.row, c.col,
                                                                                         prims))
    off_axis = [grasp_z_at(obs, r, c, prims, yaw=math.pi / 2) for r, c in ((112, 112),)]  # the bowl's middle
    assert off_axis == [pytest.approx(grasp_z(obs.height, 112, 112, prims))]


def test_the_probe_runs_and_tabulates():
    trials = run(["bowl"], objects=1, first=1, angles=1)
    assert trials and {t.region for t in trials} == {"rim", "wall", "deep"}
    assert all(set(t.z) == set(RULES) == set(t.success) for t in trials)
    text = table(trials, list(RULES), by_region=True)
    assert "bowl" in text and "jaw-line ok" in text and "deep" in text


def test_off_normal_candidates_close_at_the_given_steps_off_the_radial_rotation(world):
    world.load_scene(_scene())
    obs = world.observe()
    mask = (world.label_heightmap(obs.frame) == world.target_id) & obs.heightmap.valid
    rotations = world.geometry.heightmap.rotations
    plain = [c for c in candidates("bowl", obs.heightmap, mask, rotations, 2) if c.region == "rim"]
    off = [c for c in candidates("bowl", obs.heightmap, mask, rotations, 2, off_normal=[0, 3]) if c.region[:3] == "rim"]
    assert [c.region for c in off] == ["rim+0", "rim+3"] * 2
    radial = plain[0::2]  # the plain candidates: the radial rotation, then the next one
    assert [(c.row, c.col, c.rotation) for c in off[0::2]] == [(c.row, c.col, c.rotation) for c in radial]
    assert [c.rotation for c in off[1::2]] == [(c.rotation + 3) % (rotations // 2) for c in radial]
