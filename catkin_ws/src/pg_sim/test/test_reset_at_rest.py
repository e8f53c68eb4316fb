"""Resets answer only for a scene at rest with its target in the workspace (pg_sim.world.rest,
pg_sim.runtime.scene_swap), and leave scenes that came to rest on their own untouched."""

from __future__ import annotations

import numpy as np
import pybullet as p
import pytest

from pg_sim.runtime.runtime_types import ResetRequest, RuntimeConfig
from pg_sim.runtime.scene_swap import swap_scene
from pg_sim.runtime.sim_runtime import SimRuntime
from pg_sim.scenes.colors import resolve_color
from pg_sim.scenes.objects import set_object_pose
from pg_sim.scenes.scene import ObjectSpec, SceneSpec, load_scene
from pg_sim.world.random_scene import drop_scene, sample_drops
from pg_sim.world.rest import STILL_POS_TOL, STILL_WINDOW, bring_to_rest, moving_objects, stayed_still
from pg_sim.world.world import World

ROLLING_SEED = 1000102  # random-10: the target (obj0) still moves when World.settle gives up
AT_REST_SEED = 1000103  # random-10: everything at rest after World.settle


@pytest.fixture(scope="module")
def world():
    with World(mode="faithful") as w:  # the seeds above were chosen for the faithful mode's drops
        yield w


def poses(world: World) -> dict[str, tuple[float, ...]]:
    return {world.objects[b].name: tuple(v) for b, v in world.object_poses().items()}


def test_random_reset_answers_at_rest_and_the_target_stays_in_the_workspace():
    with SimRuntime(RuntimeConfig(real_time_factor=0.0, idle_real_time_factor=0.0)) as rt:
        result = rt.reset(ResetRequest("random", 10, ROLLING_SEED))
        assert result.success, result.message
        assert moving_objects(rt.world) == []
        assert rt.scene_state().target_in_workspace
        before = poses(rt.world)
        rt.run_for(3.0)  # nothing rolls away afterwards
        state = rt.scene_state()
        assert state.target_in_workspace
        after = poses(rt.world)
        assert max(np.abs(np.subtract(after[k][:3], before[k][:3])).max() for k in before) < 1e-3


def test_scenes_at_rest_are_not_touched(world):
    world.load_scene(load_scene("packed/case01"))
    before, t = poses(world), world.sim_time
    report = bring_to_rest(world)
    assert report.at_rest and report.time == 0.0 and report.damped == () and world.sim_time == t
    assert poses(world) == before
    drop_scene(world, sample_drops(10, AT_REST_SEED))
    before, t = poses(world), world.sim_time
    assert bring_to_rest(world).time == 0.0 and poses(world) == before and world.sim_time == t


def test_a_scene_that_does_not_come_to_rest_is_refused_and_the_previous_one_restored(world):
    world.load_scene(load_scene("packed/case02"))
    before = poses(world)
    result = swap_scene(world, sample_drops(10, ROLLING_SEED), True, rest_timeout=0.0)
    assert not result.success and "previous scene restored" in result.message
    assert "'obj0'" in result.message and "still moving" in result.message
    assert world.scene.name == "packed/case02"
    assert {k: v[:3] for k, v in poses(world).items()} == pytest.approx({k: v[:3] for k, v in before.items()})
    result = swap_scene(world, sample_drops(10, ROLLING_SEED), True, rest_timeout=3.0)
    assert result.success and moving_objects(world) == []


def test_a_target_at_rest_outside_the_workspace_is_refused(world):
    world.load_scene(load_scene("packed/case02"))
    outside = SceneSpec("outside", "green", (
        ObjectSpec("cube", None, resolve_color("green"), (0.0, 0.35, 0.0225, 0.0, 0.0, 0.0), target=True, name="goal"),
        ObjectSpec("cube", None, resolve_color("red"), (0.0, 0.0, 0.0225, 0.0, 0.0, 0.0), name="other"),
    ))
    result = swap_scene(world, outside, False, rest_timeout=3.0)
    assert not result.success and "target 'goal' (cube) came to rest outside the workspace at (0.000, 0.350" \
        in result.message, result.message
    assert world.scene.name == "packed/case02"


def test_damped_objects_get_the_default_damping_back():
    cube = ObjectSpec("cube", None, resolve_color("green"), (0.0, 0.0, 0.0225, 0.0, 0.0, 0.0), target=True, name="c")
    finals = []
    for damp_first in (True, False):
        with World() as w:
            body = w.add_object(cube)
            if damp_first:  # sliding: damped to rest, then the default damping is back
                p.resetBaseVelocity(body, [0.3, 0.0, 0.0], [0.0, 0.0, 0.0], physicsClientId=w.client)
                report = bring_to_rest(w)
                assert report.damped == ("c",) and report.at_rest
            set_object_pose(w.client, body, (0.0, 0.0, 0.1, 0.3, 0.2, 0.1))
            p.resetBaseVelocity(body, [0.3, 0.1, 0.0], [1.0, 2.0, 3.0], physicsClientId=w.client)
            for _ in range(300):
                w.step()
            finals.append(w.object_poses()[body])
    assert finals[0] == finals[1]  # bit for bit: the damping restored is PyBullet's own default


def test_an_object_jittering_in_place_counts_as_at_rest():
    q = np.array([0.0, 0.0, 0.0, 1.0])
    times = np.arange(0.0, STILL_WINDOW + 0.06, 0.05)
    jitter = [(t, np.array([0.1, 0.0, 0.01]) + 1e-4 * (-1) ** k, q) for k, t in enumerate(times)]
    assert stayed_still(jitter)
    assert not stayed_still(jitter[:5])  # a window not yet spanned
    rolling = [(t, np.array([0.1 + 0.04 * t, 0.0, 0.01]), q) for t in times]  # 4 cm/s
    assert not stayed_still(rolling)
    turning = [(t, np.zeros(3), np.array([0.0, 0.0, np.sin(0.1 * t), np.cos(0.1 * t)])) for t in times]
    assert not stayed_still(turning)
    assert not stayed_still([(t, np.array([STILL_POS_TOL * 2 * (t > 0.3), 0.0, 0.0]), q) for t in times])
