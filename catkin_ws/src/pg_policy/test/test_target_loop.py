"""pg_policy.target_loop.target_loop with a scripted heightmap source, executor and policy (the node's ROS-free
core)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from pg_core.heightmap import Heightmap
from pg_core.palette import palette_rgb
from pg_policy.decision.decision import Decision
from pg_policy.target_loop.loop_limits import LoopLimits
from pg_policy.target_loop.loop_types import Execution, LoopError, NoHeightmap, StampedHeightmap
from pg_policy.target_loop.target_loop import TargetLoop

N = 224


def heightmap(target: bool) -> Heightmap:
    color = np.zeros((N, N, 3), np.uint8)
    height = np.zeros((N, N), np.float32)
    valid = np.ones((N, N), bool)
    color[:] = (199, 178, 148)
    if target:
        color[100:120, 100:120] = palette_rgb("green")
        height[100:120, 100:120] = 0.045
    bounds = np.array([[-0.224, 0.224], [-0.224, 0.224], [0.0, 0.4]])
    return Heightmap(color, height, valid, 0.002, bounds)


class Clock:
    def __init__(self) -> None:
        self.t = 10.0

    def __call__(self) -> float:
        return self.t


class Source:
    """Serves a heightmap stamped just after any requested stamp; `target_present` says what it shows."""

    def __init__(self, clock: Clock, alive: bool = True) -> None:
        self.clock, self.alive, self.target_present, self.requests = clock, alive, True, 0

    def wait_after(self, stamp: float, timeout_s: float) -> StampedHeightmap:
        self.requests += 1
        if not self.alive:
            raise NoHeightmap(f"no heightmap within {timeout_s} s")
        self.clock.t = stamp + 0.5
        return StampedHeightmap(heightmap(self.target_present), self.clock.t)


class Executor:
    """Executes instantly; `script` lists (success, grasped, lifts_target) outcomes, the last one repeats."""

    def __init__(self, clock: Clock, source: Source, script: list[tuple[bool, bool, bool]]) -> None:
        self.clock, self.source, self.script, self.calls = clock, source, script, []

    def execute(self, decision: Decision, timeout_s: float) -> Execution:
        ok, grasped, lifts = self.script[min(len(self.calls), len(self.script) - 1)]
        self.calls.append(decision)
        self.clock.t += 3.0
        if lifts:
            self.source.target_present = False
        return Execution(ok, grasped, "left" if ok else "", "ok" if ok else "refused: unreachable", 3.0, self.clock.t)


class Policy:
    """Decides `primitive` at cell (110, 110), each time at the next rotation index (`repeat`: always rotation 4, so
    that its pushes on an unchanged scene repeat a futile push); `seen` keeps the observations' targets, `searches`
    their target memories."""

    name = "scripted"
    threshold = 0.5

    def __init__(self, primitive: str = "grasp", repeat: bool = False) -> None:
        self.primitive, self.repeat, self.resets, self.seen, self.searches = primitive, repeat, 0, [], []

    def reset(self, seed: int | None = None) -> None:
        self.resets += 1

    def act(self, obs) -> Decision:
        self.seen.append(obs.target)
        self.searches.append(obs.search)
        rot = 4 if self.repeat else len(self.seen) % 16
        return Decision(self.primitive, rot, 110, 110, 0.9, rot * math.pi / 8, 0.0, 0.0, 0.02, 0.9)

    def q_maps(self) -> dict[str, np.ndarray]:
        return {}


def make(script, primitive="grasp", alive=True, repeat=False):
    clock = Clock()
    source = Source(clock, alive)
    ex = Executor(clock, source, script)
    records = []
    loop = TargetLoop(Policy(primitive, repeat), source, ex, clock, on_action=records.append,
                      on_decision=lambda rec, shm: decided.append((rec, shm.stamp)))
    return loop, source, ex, records


decided: list = []


def test_grasps_the_target_and_reports_every_action():
    decided.clear()
    loop, _, ex, records = make([(True, False, False), (True, True, True)])
    res = loop.run("green")
    assert [(r.index, stamp) for r, stamp in decided] == [(r.index, r.heightmap_stamp) for r in records]
    assert res.success and res.grasps == 2 and res.pushes == 0 and res.failed_grasps == 1
    assert "grasped" in res.message
    assert [r.target_grasped for r in records] == [False, True]
    assert records[0].heightmap_stamp < records[0].execution.end_stamp < records[1].heightmap_stamp
    assert res.duration > 0 and len(ex.calls) == 2 and records[1].target_pixels == 400


def test_holding_a_neighbour_is_not_success():
    loop, _, _, records = make([(True, True, False)])
    res = loop.run("green", LoopLimits(max_failed_grasps=3))
    assert not res.success and res.grasps == 3 and res.failed_grasps == 3
    assert "3 failed grasps" in res.message
    assert not any(r.target_grasped for r in records)


def test_action_budget_stops_pushing():
    loop, _, ex, _ = make([(True, False, False)], primitive="push")
    res = loop.run("green", LoopLimits(max_actions=4))
    assert not res.success and res.pushes == 4 and len(ex.calls) == 4 and "budget" in res.message
    assert res.termination == "max_actions"


def test_repeated_refusals_end_the_call():
    loop, _, ex, _ = make([(False, False, False)])
    res = loop.run("green")
    assert not res.success and res.refused == 3 and len(ex.calls) == 3 and "unreachable" in res.message
    assert res.grasps == 0 and res.failed_grasps == 0


def test_unknown_colour_moves_nothing():
    loop, source, ex, _ = make([(True, True, True)])
    with pytest.raises(LoopError, match="unknown target colour 'mauve'"):
        loop.run("mauve")
    assert ex.calls == [] and source.requests == 0


def test_absent_target_moves_nothing():
    loop, source, ex, _ = make([(True, True, True)])
    source.target_present = False
    with pytest.raises(LoopError, match="not visible"):
        loop.run("green")
    assert ex.calls == []


def test_dead_camera_is_an_error_not_a_hang():
    loop, _, ex, _ = make([(True, True, True)], alive=False)
    with pytest.raises(NoHeightmap):
        loop.run("")
    assert ex.calls == []


def test_infer_executes_nothing():
    loop, _, ex, _ = make([(True, True, True)])
    rec = loop.infer("Green")
    assert rec.target == "green" and rec.decision.primitive == "grasp" and rec.execution is None
    assert ex.calls == []


def test_limits_are_validated():
    with pytest.raises(ValueError):
        LoopLimits(max_actions=0)


def test_cancel_is_checked_between_actions():
    loop, _, ex, _ = make([(True, False, False)], primitive="push")
    res = loop.run("green", cancelled=lambda: len(ex.calls) >= 2)
    assert not res.success and res.message == "cancelled" and len(ex.calls) == 2 and res.pushes == 2


def test_every_call_gives_the_free_heap_back(monkeypatch):
    """A serving node keeps freed memory (keep_freed_memory): after each run and infer, also a failed one, the free
    heap goes back to the system, so the node's RSS does not stay at the largest peak a call reached."""
    from pg_policy.target_loop import target_loop

    trims = []
    monkeypatch.setattr(target_loop, "release_free_memory", lambda: trims.append(1))
    make([(True, True, True)])[0].run("green")
    assert len(trims) == 1
    make([(True, True, True)])[0].infer("green")
    assert len(trims) == 2
    with pytest.raises(LoopError):
        make([(True, True, True)])[0].run("nocolour")
    assert len(trims) == 3
