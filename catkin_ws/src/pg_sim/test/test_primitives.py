"""Grasp and push performed by the simulated arms: success rates, displacement, refusals (DESIGN.md section 4).

The primitives are tested in the faithful simulation mode (every motion stepped); test_sim_mode.py checks that the
fast mode keeps their outcomes."""

from dataclasses import replace

import numpy as np
import pytest

from pg_core import heightmap as hm
from pg_core.action_geometry import grasp_z, push_z
from pg_sim.scenes.colors import resolve_color
from pg_sim.scenes.scene import ObjectSpec, SceneSpec
from pg_sim.world.primitives import PrimitiveExecutor, PrimitiveRefused
from pg_sim.world.world import World

STEP = 2 * np.pi / 16


@pytest.fixture(scope="module")
def world():
    w = World(mode="faithful")
    yield w
    w.close()


def _one_cube(world, x, y, yaw):
    cube = ObjectSpec(shape="cube", size=None, color=resolve_color("green"), pose=(x, y, 0.0226, 0, 0, yaw),
                      mesh=None, target=True, name="cube")
    world.load_scene(SceneSpec(name="one-cube", target="green", objects=(cube,), family="test"))
    return next(iter(world.objects))


def _heights(world, x, y):
    obs = world.observe()
    r, c = hm.world_to_pixel(x, y, obs.heightmap.bounds, obs.heightmap.resolution)
    return obs.heightmap.height, r, c


def test_isolated_cube_grasped_19_of_20(world):
    rng = np.random.default_rng(7)
    ex = PrimitiveExecutor(world)
    ws = world.geometry.workspace
    ok = []
    for _ in range(20):
        x, y = rng.uniform(ws.x[0] + 0.04, ws.x[1] - 0.04), rng.uniform(ws.y[0] + 0.04, ws.y[1] - 0.04)
        cube_yaw = rng.uniform(-np.pi, np.pi)
        body = _one_cube(world, x, y, cube_yaw)
        height, r, c = _heights(world, x, y)
        yaw = round((cube_yaw % (np.pi / 2)) / STEP) * STEP  # nearest of the 16 rotations
        res = ex.grasp(x, y, grasp_z(height, r, c, world.geometry.primitives), yaw)
        ok.append(res.grasped and res.grasped_object == body and res.target_grasped)
    assert sum(ok) >= 19, ok


def test_push_moves_cube_along_yaw(world):
    ex = PrimitiveExecutor(world)
    rng = np.random.default_rng(11)
    for _ in range(3):
        yaw = int(rng.integers(16)) * STEP
        d = np.array([np.cos(yaw), np.sin(yaw)])
        centre = -0.06 * d  # leave room for 0.13 m of travel inside the workspace
        body = _one_cube(world, centre[0], centre[1], yaw)
        start = centre - 0.035 * d
        height, r, c = _heights(world, *start)
        res = ex.push(start[0], start[1], push_z(height, r, c, world.geometry.primitives), yaw)
        assert res.executed, res.message
        moved = world.object_poses()[body][:2] - centre
        along = float(moved @ d)
        assert 0.10 <= along <= 0.14, (yaw, moved)
        assert abs(float(moved @ [-d[1], d[0]])) < 0.03


def test_grasp_at_empty_spot_fails(world):
    _one_cube(world, 0.15, 0.15, 0.0)
    res = PrimitiveExecutor(world).grasp(-0.1, -0.1, 0.02, 0.0)
    assert res.executed and not res.grasped and res.grasped_object is None


@pytest.mark.parametrize("xyz", [(0.3, 0.0, 0.02), (0.0, -0.25, 0.02), (0.0, 0.0, -0.01), (0.0, 0.0, 0.35)])
def test_outside_workspace_is_refused_and_nothing_moves(world, xyz):
    _one_cube(world, 0.0, 0.0, 0.3)
    before_q = {a: d.joints() for a, d in world.arms.items()}
    before_obj = world.object_poses()
    t0 = world.sim_time
    for prim in (PrimitiveExecutor(world).grasp, PrimitiveExecutor(world).push):
        with pytest.raises(PrimitiveRefused, match="outside the workspace"):
            prim(*xyz, 0.0)
    assert world.sim_time == t0
    for a, d in world.arms.items():
        np.testing.assert_array_equal(d.joints(), before_q[a])
    for b, pose in world.object_poses().items():
        np.testing.assert_array_equal(pose, before_obj[b])


def test_unknown_arm_refused(world):
    with pytest.raises(PrimitiveRefused, match="unknown arm"):
        PrimitiveExecutor(world).grasp(0.0, 0.0, 0.02, 0.0, arm="middle")


def _cube(name, color, x, z, size, target=False):
    return ObjectSpec(shape="cube", size=(size, size, size), color=resolve_color(color), pose=(x, 0.0, z, 0, 0, 0),
                      mesh=None, target=target, name=name)


@pytest.mark.parametrize("layout", ["stacked", "side-by-side"])
def test_a_target_lifted_with_a_neighbour_counts_as_grasped_and_both_leave(world, layout):
    # The jaw closes on the target and a neighbour together: both leave the table, the target is credited (a rule
    # that credited the lowest body id in the jaw reported the neighbour and carried the target off in the gripper).
    s = 0.03
    if layout == "stacked":
        objs = (_cube("below", "blue", 0.0, s / 2, s), _cube("target", "green", 0.0, 1.5 * s, s, target=True))
    else:
        objs = (_cube("left", "blue", -s / 2 - 0.001, s / 2, s),
                _cube("target", "green", s / 2 + 0.001, s / 2, s, target=True))
    world.load_scene(SceneSpec(name=layout, target="green", objects=objs, family="test"))
    target = world.target_id
    (below,) = set(world.objects) - {target}
    height, r, c = _heights(world, 0.0, 0.0)
    res = PrimitiveExecutor(world).grasp(0.0, 0.0, grasp_z(height, r, c, world.geometry.primitives), 0.0)
    assert res.grasped and res.target_grasped and res.grasped_object == target, res
    assert below not in world.objects and target not in world.objects


def _record_driver(world, monkeypatch, events):
    """Wraps every arm driver's gripper() and follow() (the real ones still run) to log ("open"/"close", m) and
    ("move", final joints) in call order."""
    for drv in world.arms.values():
        def gripper(opening, *a, _real=drv.gripper, **k):
            events.append(("open" if opening > 0 else "close", opening))
            return _real(opening, *a, **k)

        def follow(waypoints, *a, _real=drv.follow, **k):
            events.append(("move", np.asarray(waypoints[-1], dtype=float)))
            return _real(waypoints, *a, **k)

        monkeypatch.setattr(drv, "gripper", gripper)
        monkeypatch.setattr(drv, "follow", follow)


def _home_index(world, events):
    homes = [np.asarray(a.home) for a in world.geometry.robot.arms.values()]
    return next(i for i, (kind, v) in enumerate(events)
                if kind == "move" and any(np.allclose(v, h, atol=1e-6) for h in homes))


def test_a_failed_grasp_releases_at_the_lift_pose_before_going_home(world, monkeypatch):
    # what a closed jaw snags (an edge, a thin part) falls back at the grasp site instead of travelling home with it
    _one_cube(world, 0.15, 0.15, 0.0)
    events = []
    _record_driver(world, monkeypatch, events)
    res = PrimitiveExecutor(world).grasp(-0.1, -0.1, 0.02, 0.0)
    assert res.executed and not res.grasped
    close = events.index(("close", 0.0))
    opens = [i for i, (kind, _) in enumerate(events) if kind == "open" and i > close]
    assert opens and opens[0] < _home_index(world, events), [e[0] for e in events]


def test_a_successful_grasp_keeps_the_jaw_closed_until_home(world, monkeypatch):
    _one_cube(world, 0.0, 0.0, 0.0)
    events = []
    _record_driver(world, monkeypatch, events)
    height, r, c = _heights(world, 0.0, 0.0)
    res = PrimitiveExecutor(world).grasp(0.0, 0.0, grasp_z(height, r, c, world.geometry.primitives), 0.0)
    assert res.grasped, res.message
    close = events.index(("close", 0.0))
    opens = [i for i, (kind, _) in enumerate(events) if kind == "open" and i > close]
    assert opens and opens[0] > _home_index(world, events)


def _with_stop_force(geometry, newtons):
    return replace(geometry, primitives=replace(geometry.primitives, grasp_stop_force=newtons))


@pytest.mark.parametrize("newtons", [0.0, 10.0])
def test_guarded_descent_stops_a_finger_on_an_object_instead_of_throwing_it(world, newtons):
    # One finger comes down on the cube's top face (jaw centre 4.5 cm beside the cube's, closing along x). Driven to
    # the planned depth, the finger presses into the cube and the contact solver throws it (1.6 cm and 11 degrees
    # here); a guarded descent stops on contact, the jaw closes above it and the cube stays within a few mm.
    with World(_with_stop_force(world.geometry, newtons)) as guarded:
        body = _one_cube(guarded, 0.0, 0.0, 0.0)
        height, r, c = _heights(guarded, 0.0, 0.0)
        z = grasp_z(height, r, c, guarded.geometry.primitives)
        res = PrimitiveExecutor(guarded).grasp(-0.045, 0.0, z, 0.0)
        moved = float(np.linalg.norm(np.array(guarded.object_poses()[body][:2])))
    assert res.executed and not res.grasped
    if newtons > 0:
        assert moved < 0.015, moved
    else:
        assert moved > 0.01, moved


def test_guarded_descent_still_grasps_a_cube_between_the_fingers(world):
    with World(_with_stop_force(world.geometry, 10.0)) as guarded:
        body = _one_cube(guarded, 0.05, -0.05, 0.3)
        height, r, c = _heights(guarded, 0.05, -0.05)
        res = PrimitiveExecutor(guarded).grasp(0.05, -0.05, grasp_z(height, r, c, guarded.geometry.primitives),
                                               round(0.3 / STEP) * STEP)
    assert res.grasped and res.grasped_object == body, res.message


@pytest.mark.parametrize("newtons", [0.0, 30.0])
def test_guarded_push_descent_pushes_a_cube_it_starts_over_at_push_speed(world, monkeypatch, newtons):
    # The closed fingers start over a 45 mm cube's top: push z (local max - push_depth) drives them 1 cm into it and
    # the contact solver shoves it off at 0.3-0.5 m/s; a guarded descent stops on the top face and the push carries
    # the cube along at about push_speed (0.1 m/s).
    import math

    import pybullet as p

    peak, cube = [0.0], []
    step = World.step

    def timed_step(self):  # the cube's fastest speed (m/s) once it is loaded
        t = step(self)
        if cube:
            peak[0] = max(peak[0], math.hypot(*p.getBaseVelocity(cube[0], physicsClientId=self.client)[0]))
        return t

    monkeypatch.setattr(World, "step", timed_step)
    geometry = replace(world.geometry, primitives=replace(world.geometry.primitives, push_stop_force=newtons))
    with World(geometry, mode="faithful") as guarded:
        body = _one_cube(guarded, 0.0, 0.0, 0.0)
        height, r, c = _heights(guarded, 0.0, 0.0)
        z = push_z(height, r, c, guarded.geometry.primitives)
        cube.append(body)
        res = PrimitiveExecutor(guarded).push(0.0, 0.0, z, 0.0)
    assert res.executed and peak[0] > 0.05, (res.message, peak)
    if newtons > 0:
        assert peak[0] < 0.2, peak
    else:
        assert peak[0] > 0.25, peak


@pytest.mark.parametrize("width", [0.012, 0.02, 0.03])
def test_light_narrow_block_grasped_at_grasp_min_z(world, width):
    """A 10 g block 40 mm tall and 12-30 mm wide, alone, grasped at its centre with the fingertips at grasp_min_z:
    with the world's 50 solver iterations the squeezing pads slide over it (the jaw closes empty); every grasp
    squeezes with SQUEEZE_SOLVER_ITERATIONS."""
    block = ObjectSpec(shape="cube", size=(width, width, 0.04), color=resolve_color("green"),
                       pose=(0.05, -0.03, 0.0205, 0, 0, 0), mesh=None, target=True, name="block", mass=0.01)
    world.load_scene(SceneSpec(name="light-block", target="green", objects=(block,), family="test"))
    x, y = world.object_poses()[world.target_id][:2]
    res = PrimitiveExecutor(world).grasp(float(x), float(y), world.geometry.primitives.grasp_min_z, 0.0)
    assert res.target_grasped, res.message


def test_rubber_pads_hold_a_triangle_prism_closed_on_across_its_slanted_faces(world):
    """A triangular prism alone, grasped at its centre at each of the 16 rotations. With the finger pads' friction
    (gripper.pad_friction 1.0: 0.7 against the prism) the jaw lifts it at 12 of them; with PyBullet's default 0.5
    (0.35 against it) the closing jaw squeezes it out at 11 rotations and throws it up to 9 cm (fast mode: 14 of 16
    lifted against 9, thrown up to 14 cm)."""
    ex = PrimitiveExecutor(world)
    lifted = 0
    for k in range(16):
        prism = ObjectSpec(shape="triangle", size=None, color=resolve_color("green"), pose=(0.0, 0.0, 0.03, 0, 0, 0.3),
                           mesh=None, target=True, name="prism")
        world.load_scene(SceneSpec(name="one-prism", target="green", objects=(prism,), family="test"))
        body = next(iter(world.objects))
        start = np.array(world.object_poses()[body][:2])
        height, r, c = _heights(world, *start)
        res = ex.grasp(float(start[0]), float(start[1]), grasp_z(height, r, c, world.geometry.primitives), k * STEP)
        lifted += res.target_grasped
    assert lifted >= 11, lifted
