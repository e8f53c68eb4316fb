"""The simulator's memory stays flat across resets: objects share their PyBullet shapes per shape key, and the
runtime starts every reset from a new world (pg_sim.world.world, pg_sim.runtime.sim_runtime), which also makes a
(scene, seed) settle the same whatever ran before. The long form of the measurement
is `python3 -m pg_sim.runtime.reset_soak memory --resets 500` (docs/RELIABILITY.md)."""

from __future__ import annotations

import gc
import weakref

import numpy as np
import pybullet as p

from pg_sim.runtime import sim_runtime
from pg_sim.runtime.reset_soak import fuzzed_requests, quiet_config, reset_memory
from pg_sim.runtime.runtime_types import ResetRequest
from pg_sim.runtime.sim_runtime import SimRuntime
from pg_sim.scenes.colors import resolve_color
from pg_sim.scenes.scene import ObjectSpec
from pg_sim.world.world import World, shape_key

MAX_SLOPE = 5.0  # MB per 100 resets after the warm-up


def _cube(name: str, color: str, x: float, size: tuple[float, float, float] | None = None,
          mass: float | None = None) -> ObjectSpec:
    return ObjectSpec("cube", size, resolve_color(color), (x, 0.0, 0.0225, 0.0, 0.0, 0.0), name=name,
                      target=name == "a", mass=mass)


def test_objects_of_one_key_share_their_shapes_and_keep_their_own_colours():
    with World() as w:
        a = w.add_object(_cube("a", "green", -0.05))
        b = w.add_object(_cube("b", "red", 0.05))
        c = w.add_object(_cube("c", "blue", 0.0, (0.03, 0.03, 0.03)))
        assert len(w.shapes_) == 2 and w.bodies_created == 3
        assert shape_key(w.objects[a]) == shape_key(w.objects[b]) != shape_key(w.objects[c])
        w.remove_object(b)
        b = w.add_object(_cube("b", "red", 0.05, mass=0.2))
        assert len(w.shapes_) == 2 and w.bodies_created == 4  # re-added: no new shapes
        frame = w.capture()
        for body, rgb in ((a, (0, 255, 0)), (c, (0, 0, 255))):
            mask = w.object_mask(frame, body)
            assert mask.any()
            mean = frame.color[mask].mean(axis=0)
            assert int(np.argmax(mean)) == int(np.argmax(rgb)), (body, mean)
        mass = {b: p.getDynamicsInfo(b, -1, physicsClientId=w.client)[0] for b in w.objects}
        assert mass[b] == 0.2 and mass[a] == mass[c] != 0.2  # a shared shape, a mass of its own


def test_every_reset_starts_from_a_new_world_and_sim_time_carries_on():
    with SimRuntime(quiet_config(scene="packed/case01")) as rt:
        first = rt.world
        t = rt.sim_time
        result = rt.reset(ResetRequest("random", 10, 1000002))
        assert result.success, result.message
        assert rt.world is not first and rt.worlds_built == 2 and rt.sim_time > t
        assert not p.isConnected(first.client)  # the old world is closed
        rt.run_for(0.1)
        assert rt.joint_state().positions.shape == (len(rt.joint_names),)
        state = rt.scene_state()
        assert state.target_in_workspace and len(state.objects) == 10


def test_a_replaced_world_is_freed_at_once_not_by_the_cyclic_collector():
    """A closed world holds no reference cycle (its arm drivers held its `step`): the node's memory does not
    depend on when Python's cyclic garbage collector last ran."""
    gc.collect()
    gc.disable()
    try:
        with SimRuntime(quiet_config(scene="packed/case01")) as rt:
            rt.capture(force=True)
            first = weakref.ref(rt.world)
            camera = weakref.ref(rt.world.camera)
            assert rt.reset(ResetRequest("packed/case02")).success
            assert first() is None and camera() is None
    finally:
        gc.enable()


def test_a_scene_and_seed_settle_the_same_whatever_ran_before():
    """A used world keeps its broadphase history: the same (scene, seed) settled differently after other scenes."""
    def poses(rt):
        return {o.name: np.asarray(o.position) for o in rt.scene_state().objects}

    with SimRuntime(quiet_config(scene="packed/case01")) as rt:
        assert rt.reset(ResetRequest("random", 15, 1000014)).success
        first = poses(rt)
        for seed in (1000001, 1000002, 1000003):
            rt.reset(ResetRequest("random", 12, seed))
        assert rt.reset(ResetRequest("random", 15, 1000014)).success
        again = poses(rt)
    assert again.keys() == first.keys()
    assert max(float(np.abs(again[k] - first[k]).max()) for k in first) < 1e-9


def test_a_refused_reset_keeps_the_scene(monkeypatch):
    with SimRuntime(quiet_config(scene="packed/case01")) as rt:
        result = rt.reset(ResetRequest("random", 10, 1000002))
        assert result.success
        monkeypatch.setattr(sim_runtime, "swap_scene", _refuse)
        before = {o.name: o.position for o in rt.scene_state().objects}
        assert not rt.reset(ResetRequest("random", 10, 1000003)).success
        after = {o.name: o.position for o in rt.scene_state().objects}
        assert after.keys() == before.keys()
        assert max(np.abs(np.subtract(after[k], before[k])).max() for k in before) < 1e-6
        assert rt.worlds_built == 4  # the refused scene's world is replaced too, not re-used for the old objects


def _refuse(world: World, *args: object) -> sim_runtime.ResetResult:
    return sim_runtime.ResetResult(False, "refused by the test")


def test_rss_is_flat_across_random_resets():
    """120 random resets (1-15 blocks, fuzzed seeds): the RSS slope after 20 warm-up resets stays below
    MAX_SLOPE MB per 100 resets (it was about 40 when every object built its own shapes)."""
    with SimRuntime(quiet_config()) as rt:
        run = reset_memory(rt, fuzzed_requests(120, 7, (("random", 1, 15),)), warmup=20)
    assert run.accepted >= 110, run.summary()
    assert run.worlds_built >= 2, run.summary()
    assert run.slope < MAX_SLOPE, run.summary()
