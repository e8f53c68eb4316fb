"""Shipped scenes and the random generator: load, settle, stay in the workspace, no interpenetration, target visible."""

import numpy as np
import pybullet as p
import pytest

from pg_sim.scenes.scene import find_scene, list_scenes, load_scene
from pg_sim.world.random_scene import drop_scene, sample_drops
from pg_sim.world.world import World

SHIPPED = list_scenes()


@pytest.fixture(scope="module")
def world():
    w = World()
    yield w
    w.close()


def _check_settled(world):
    ws = world.geometry.workspace
    for body, pose in world.object_poses().items():
        assert ws.x[0] <= pose[0] <= ws.x[1] and ws.y[0] <= pose[1] <= ws.y[1], (world.objects[body].name, pose)
        assert pose[2] > -0.005, (world.objects[body].name, pose)
    worst = min((c[8] for c in p.getContactPoints(physicsClientId=world.client)), default=0.0)
    assert worst > -0.002, f"interpenetration of {-worst * 1000:.1f} mm"
    frame = world.capture()
    visible = int(np.sum(world.label_heightmap(frame) == world.target_id))
    assert visible >= 30, f"target visible in only {visible} heightmap cells"


def test_families_are_shipped():
    assert sum(n.startswith("packed/") for n in SHIPPED) == 9
    assert sum(n.startswith("household/") for n in SHIPPED) == 4


@pytest.mark.parametrize("name", SHIPPED)
def test_shipped_scene_settles(world, name):
    scene = load_scene(find_scene(name))
    world.load_scene(scene)
    assert world.target_id is not None
    assert len(world.objects) == len(scene.objects)
    if name.startswith("packed/"):
        assert 6 <= len(scene.objects) <= 13  # 5-12 blocks around the target
    _check_settled(world)


@pytest.mark.parametrize("n", [10, 20])
def test_random_scene_settles(world, n):
    drop_scene(world, sample_drops(n, seed=n))
    assert len(world.objects) == n
    _check_settled(world)


def test_same_seed_same_scene_different_seed_different_scene(world):
    a = drop_scene(world, sample_drops(8, seed=123))
    b = drop_scene(world, sample_drops(8, seed=123))
    c = drop_scene(world, sample_drops(8, seed=124))
    pa, pb, pc = (np.array([o.pose for o in s.objects]) for s in (a, b, c))
    np.testing.assert_allclose(pa, pb, atol=1e-9)
    assert [o.shape for o in a.objects] == [o.shape for o in b.objects]
    assert not np.allclose(pa[:, :2], pc[:, :2], atol=1e-3)


def test_target_outside_after_the_retries_is_dropped_again_others_may_stay_out(world):
    """With no scene retries, a target and a neighbour dropped beyond the workspace edge: the target is re-dropped
    until it rests inside (the protocol's reset); the neighbour stays where it fell."""
    drops = sample_drops(2, seed=5)
    out_x = world.geometry.workspace.x[1] + 0.08
    moved = tuple(o.__class__(**{**o.__dict__, "pose": (out_x, 0.0, 0.05, 0.0, 0.0, 0.0)}) for o in drops.objects)
    scene = drop_scene(world, drops.__class__(**{**drops.__dict__, "objects": moved}), retries=0)
    ws = world.geometry.workspace
    poses = world.object_poses()
    target, other = world.target_id, next(b for b in poses if b != world.target_id)
    assert ws.x[0] < poses[target][0] < ws.x[1] and ws.y[0] < poses[target][1] < ws.y[1]
    assert poses[other][0] > ws.x[1]
    assert sum(o.target for o in scene.objects) == 1
