"""Simulation modes (pg_sim.world.sim_mode): the fast mode's static table and kinematic transit keep what the
camera sees and what the primitives do; the transit refuses a path that passes an object."""

from __future__ import annotations

import numpy as np
import pybullet as p
import pytest

from pg_core import heightmap as hm
from pg_core.action_geometry import grasp_z, push_z
from pg_sim.scenes.colors import resolve_color
from pg_sim.scenes.scene import ObjectSpec, SceneSpec, load_scene
from pg_sim.world.primitives import PrimitiveExecutor
from pg_sim.world.sim_mode import SIM_MODES, get_sim_mode
from pg_sim.world.static_table import table_link
from pg_sim.world.transit import arm_links, clear_of_objects, samples, teleport
from pg_sim.world.world import World

STEP = 2 * np.pi / 16


@pytest.fixture(scope="module")
def fast():
    with World(mode="fast") as w:
        yield w


def _cube(x: float, y: float, yaw: float = 0.0, z: float = 0.0226, name: str = "cube") -> ObjectSpec:
    return ObjectSpec(shape="cube", size=None, color=resolve_color("green"), pose=(x, y, z, 0, 0, yaw), mesh=None,
                      target=True, name=name)


def _one_cube(world: World, x: float, y: float, yaw: float = 0.0) -> int:
    world.load_scene(SceneSpec(name="one-cube", target="green", objects=(_cube(x, y, yaw),), family="test"))
    return next(iter(world.objects))


def test_unknown_mode_is_refused_naming_the_known_ones():
    with pytest.raises(ValueError, match="unknown simulation mode 'quick' \\(known: fast, faithful\\)"):
        World(mode="quick")
    assert get_sim_mode(SIM_MODES["fast"]) is SIM_MODES["fast"]


def test_the_fast_table_is_a_static_body_and_the_robot_link_no_longer_collides(fast):
    assert fast.table_body is not None
    link = table_link(fast.client, fast.robot.body)
    body = _one_cube(fast, 0.0, 0.0)
    contacts = p.getContactPoints(bodyA=body, physicsClientId=fast.client)
    assert contacts and {c[2] for c in contacts} == {fast.table_body}
    assert not p.getContactPoints(bodyA=fast.robot.body, linkIndexA=link, physicsClientId=fast.client)


def test_both_modes_see_the_same_camera_images_and_rest_objects_at_the_same_height():
    scene = load_scene("packed/case01")
    frames, heights = {}, {}
    for mode in SIM_MODES:
        with World(mode=mode) as w:
            w.load_scene(scene, settle=False)
            frames[mode] = w.capture()
            w.load_scene(SceneSpec(name="one", target="green", objects=(_cube(0.05, 0.0, z=0.03),), family="t"))
            heights[mode] = next(iter(w.object_poses().values()))[2]
    np.testing.assert_array_equal(frames["fast"].color, frames["faithful"].color)
    np.testing.assert_array_equal(frames["fast"].depth, frames["faithful"].depth)
    assert heights["fast"] == pytest.approx(heights["faithful"], abs=5e-4)


def test_fast_mode_grasps_an_isolated_cube_9_of_10_in_less_simulated_time(fast):
    rng = np.random.default_rng(7)
    ex = PrimitiveExecutor(fast)
    ws = fast.geometry.workspace
    ok, sim = [], []
    for _ in range(10):
        x, y = rng.uniform(ws.x[0] + 0.04, ws.x[1] - 0.04), rng.uniform(ws.y[0] + 0.04, ws.y[1] - 0.04)
        cube_yaw = rng.uniform(-np.pi, np.pi)
        body = _one_cube(fast, x, y, cube_yaw)
        obs = fast.observe()
        r, c = hm.world_to_pixel(x, y, obs.heightmap.bounds, obs.heightmap.resolution)
        yaw = round((cube_yaw % (np.pi / 2)) / STEP) * STEP
        res = ex.grasp(x, y, grasp_z(obs.heightmap.height, r, c, fast.geometry.primitives), yaw)
        ok.append(res.grasped and res.grasped_object == body and res.target_grasped)
        sim.append(res.sim_time)
    assert sum(ok) >= 9, ok
    home = {a: np.asarray(fast.geometry.robot.arms[a].home) for a in fast.arms}
    for a, drv in fast.arms.items():  # back home, fingers open
        np.testing.assert_allclose(drv.joints(), home[a], atol=2e-3)
        assert drv.opening() == pytest.approx(fast.geometry.gripper.max_opening, abs=2e-3)
    assert np.median(sim) < 2.5  # faithful: about 3.3 s (the approach and the return home are stepped)


def test_fast_mode_push_moves_a_cube_along_yaw(fast):
    ex = PrimitiveExecutor(fast)
    yaw = 3 * STEP
    d = np.array([np.cos(yaw), np.sin(yaw)])
    centre = -0.06 * d
    body = _one_cube(fast, centre[0], centre[1], yaw)
    start = centre - 0.035 * d
    obs = fast.observe()
    r, c = hm.world_to_pixel(*start, obs.heightmap.bounds, obs.heightmap.resolution)
    res = ex.push(start[0], start[1], push_z(obs.heightmap.height, r, c, fast.geometry.primitives), yaw)
    assert res.executed, res.message
    moved = fast.object_poses()[body][:2] - centre
    assert 0.10 <= float(moved @ d) <= 0.14, moved


def test_a_transit_through_an_object_is_refused_and_moves_nothing(fast):
    arm = next(iter(fast.arms))
    drv = fast.arms[arm]
    home = np.asarray(fast.geometry.robot.arms[arm].home)
    away = home.copy()
    away[0] += 0.6  # swing the shoulder: the arm sweeps an arc at its home height
    links = arm_links(fast, arm)
    fast.clear_objects()
    drv.place(home, fast.geometry.gripper.max_opening)
    assert clear_of_objects(fast, links, 0.02)
    mid = samples([home, away], 0.05)[len(samples([home, away], 0.05)) // 2]
    drv.place(mid, None, drv.finger_positions())
    tcp = np.array(p.getLinkState(fast.robot.body, drv.arm.tcp, physicsClientId=fast.client)[4])
    drv.place(home, None, drv.finger_positions())
    fast.add_object(_cube(tcp[0], tcp[1], z=tcp[2], name="in-the-way"))  # floats where the swing passes
    before = drv.joints(), drv.finger_positions()
    assert not teleport(fast, drv, [home, away], links, fast.mode, fast.geometry.gripper.max_opening)
    np.testing.assert_array_equal(drv.joints(), before[0])
    assert drv.finger_positions() == before[1]
    fast.clear_objects()
    assert teleport(fast, drv, [home, away], links, fast.mode, fast.geometry.gripper.max_opening)
    np.testing.assert_allclose(drv.joints(), away, atol=1e-9)
    drv.reset(home, fast.geometry.gripper.max_opening)


def test_the_faithful_mode_steps_every_motion():
    with World(mode="faithful") as w:
        assert w.table_body is None
        body = _one_cube(w, 0.0, 0.0)
        obs = w.observe()
        r, c = hm.world_to_pixel(0.0, 0.0, obs.heightmap.bounds, obs.heightmap.resolution)
        res = PrimitiveExecutor(w).grasp(0.0, 0.0, grasp_z(obs.heightmap.height, r, c, w.geometry.primitives), 0.0)
        assert res.target_grasped and res.grasped_object == body
        assert res.sim_time > 3.0
