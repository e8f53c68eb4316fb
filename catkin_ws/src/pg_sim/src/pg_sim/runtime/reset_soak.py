"""Long runs of the simulator's reset (no ROS): resident memory across many resets, and whether objects stay still
after every accepted reset.

`reset_memory` resets a `SimRuntime` N times and fits the resident set size (RSS, MB) after each reset with a line
over the resets after a warm-up: its slope, in MB per 100 resets, is the growth a long-running sim node shows.
`reset_stillness` resets N times and, after each accepted reset, steps ``window`` s of sim time (as the running node
does after answering) and records how far every object moved (m, its base position).

Requests are fuzzed: generated families with random object counts and evaluation-style seeds (>= 1 000 000), and
shipped scenes, drawn from one seed, so a run is reproducible.

Command line (prints a summary; ``--json FILE`` writes every figure):

    python3 -m pg_sim.runtime.reset_soak memory --resets 500 --warmup 20
    python3 -m pg_sim.runtime.reset_soak still --resets 500
"""

from __future__ import annotations

import argparse
import json
import os
import random
import sys
import time
from collections.abc import Sequence
from dataclasses import asdict, dataclass, field

import numpy as np
import pybullet as p

from pg_sim.runtime.runtime_types import ResetRequest, RuntimeConfig
from pg_sim.runtime.sim_runtime import SimRuntime

# (scene or family, smallest and largest object count; 0, 0 for a shipped scene)
MEMORY_MIX: tuple[tuple[str, int, int], ...] = (
    ("random", 1, 15), ("dense", 1, 15), ("novel", 1, 15), ("mixed", 1, 15), ("household", 1, 12),
    ("packed/case01", 0, 0), ("household/case11", 0, 0),
)
STILL_MIX: tuple[tuple[str, int, int], ...] = (
    ("random", 10, 10), ("random", 15, 15), ("household", 10, 10), ("random", 1, 15), ("dense", 1, 15),
    ("novel", 1, 15), ("mixed", 1, 15),
)
STILL_WINDOW = 1.0     # s of sim time watched after each accepted reset
STILL_TOLERANCE = 5e-3  # m: an object moving more than this within the window was not at rest when accepted


def quiet_config(**overrides: object) -> RuntimeConfig:
    """A runtime that steps as fast as possible and reports nothing periodically (no renders, no joint states)."""
    base: dict[str, object] = dict(real_time_factor=0.0, idle_real_time_factor=0.0, camera_rate=0.0,
                                   joint_state_rate=0.0, clock_rate=0.0, scene_state_rate=0.0)
    base.update(overrides)
    return RuntimeConfig(**base)  # type: ignore[arg-type]


def fuzzed_requests(count: int, seed: int, mix: Sequence[tuple[str, int, int]]) -> list[ResetRequest]:
    """``count`` requests drawn uniformly from ``mix``; generated ones get an object count in its range and a seed
    in [1 000 000, 2 000 000)."""
    rng = random.Random(seed)
    out = []
    for _ in range(count):
        scene, low, high = mix[rng.randrange(len(mix))]
        if high == 0:
            out.append(ResetRequest(scene))
        else:
            out.append(ResetRequest(scene, rng.randint(low, high), 1_000_000 + rng.randrange(1_000_000)))
    return out


def rss_mb() -> float:
    """This process's resident set size in MB (10^6 bytes), from /proc/self/statm."""
    with open("/proc/self/statm") as f:
        pages = int(f.read().split()[1])
    return pages * os.sysconf("SC_PAGE_SIZE") / 1e6


def slope_per_100(values: Sequence[float]) -> float:
    """Least-squares slope of ``values`` (one per reset) in units per 100 resets (0 for fewer than two)."""
    if len(values) < 2:
        return 0.0
    x = np.arange(len(values), dtype=np.float64)
    return float(np.polyfit(x, np.asarray(values, dtype=np.float64), 1)[0] * 100.0)


def describe(req: ResetRequest) -> str:
    return f"{req.scene} n={req.num_objects} seed={req.seed}" if req.num_objects else req.scene


@dataclass
class MemoryRun:
    """RSS (MB) after each reset; ``slope`` (MB per 100 resets) is fitted over the resets after ``warmup``."""

    resets: int
    warmup: int
    accepted: int
    rss: list[float]
    slope: float
    worlds_built: int
    wall_s: float

    def summary(self) -> str:
        after = self.rss[self.warmup] if len(self.rss) > self.warmup else float("nan")
        return (f"{self.resets} resets ({self.accepted} accepted), RSS {self.rss[0]:.1f} MB after the first, "
                f"{after:.1f} MB after reset {self.warmup}, {self.rss[-1]:.1f} MB at the end; slope after the "
                f"warm-up {self.slope:.2f} MB per 100 resets; worlds built {self.worlds_built}; {self.wall_s:.0f} s")


def reset_memory(runtime: SimRuntime, requests: Sequence[ResetRequest], warmup: int) -> MemoryRun:
    """Reset through ``requests`` and fit the RSS after each one (see the module docstring)."""
    t0 = time.monotonic()
    rss, accepted = [], 0
    for req in requests:
        accepted += int(runtime.reset(req).success)
        rss.append(rss_mb())
    return MemoryRun(len(requests), warmup, accepted, rss, slope_per_100(rss[warmup:]), runtime.worlds_built,
                     time.monotonic() - t0)


@dataclass
class StillRun:
    """Per accepted reset, the largest base displacement (m) of any object over ``window`` s of sim time after
    the answer; ``worst`` lists the largest few as (displacement m, request, object name); ``refusals`` counts the
    refused resets by reason (REFUSAL_KINDS)."""

    resets: int
    accepted: int
    window: float
    displacements: list[float]
    worst: list[tuple[float, str, str]] = field(default_factory=list)
    refusals: dict[str, int] = field(default_factory=dict)
    wall_s: float = 0.0

    def over(self, tolerance: float = STILL_TOLERANCE) -> int:
        return sum(d > tolerance for d in self.displacements)

    def summary(self, tolerance: float = STILL_TOLERANCE) -> str:
        top = max(self.displacements, default=0.0)
        worst = f" (worst: {self.worst[0][1]}, {self.worst[0][2]})" if self.worst else ""
        refused = ", ".join(f"{kind} {n}" for kind, n in sorted(self.refusals.items()))
        return (f"{self.resets} resets, {self.accepted} accepted; largest motion in the {self.window:g} s after an "
                f"accepted reset {top * 1000:.2f} mm{worst}; {self.over(tolerance)} over "
                f"{tolerance * 1000:g} mm; refused: {refused or 'none'}; {self.wall_s:.0f} s")


REFUSAL_KINDS: tuple[tuple[str, str], ...] = (  # (text in the message, kind), first match wins
    ("still moving (creeping)", "creeping"), ("damping while watched", "moving while watched"),
    ("still moving", "not at rest"), ("outside the workspace", "target outside"),
)


def refusal_kind(message: str) -> str:
    """The kind (REFUSAL_KINDS) of a refused reset's message; "other" when none matches."""
    return next((kind for text, kind in REFUSAL_KINDS if text in message), "other")


def object_positions(runtime: SimRuntime) -> dict[int, np.ndarray]:
    w = runtime.world
    return {b: np.asarray(p.getBasePositionAndOrientation(b, physicsClientId=w.client)[0]) for b in w.objects}


def reset_stillness(runtime: SimRuntime, requests: Sequence[ResetRequest], window: float = STILL_WINDOW,
                    keep_worst: int = 5) -> StillRun:
    """Reset through ``requests``; after each accepted one step ``window`` s and record the largest motion."""
    t0 = time.monotonic()
    run = StillRun(len(requests), 0, window, [])
    worst: list[tuple[float, str, str]] = []
    for req in requests:
        result = runtime.reset(req)
        if not result.success:
            kind = refusal_kind(result.message)
            run.refusals[kind] = run.refusals.get(kind, 0) + 1
            continue
        run.accepted += 1
        before = object_positions(runtime)
        runtime.run_for(window)
        after = object_positions(runtime)
        moved = {b: float(np.linalg.norm(after[b] - before[b])) for b in before}
        body = max(moved, key=lambda b: moved[b], default=None)
        top = moved[body] if body is not None else 0.0
        run.displacements.append(top)
        if body is not None:
            worst.append((top, describe(req), runtime.world.objects[body].name))
            worst = sorted(worst, reverse=True)[:keep_worst]
    run.worst = worst
    run.wall_s = time.monotonic() - t0
    return run


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python3 -m pg_sim.runtime.reset_soak", description=__doc__.split("\n\n")[0])
    ap.add_argument("check", choices=("memory", "still"))
    ap.add_argument("--resets", type=int, default=500)
    ap.add_argument("--warmup", type=int, default=20, help="memory: resets before the slope is fitted")
    ap.add_argument("--seed", type=int, default=0, help="seed of the request draw")
    ap.add_argument("--window", type=float, default=STILL_WINDOW, help="still: sim seconds watched per reset")
    ap.add_argument("--json", default="", help="write every figure to this file")
    args = ap.parse_args(argv)
    with SimRuntime(quiet_config()) as rt:
        if args.check == "memory":
            mem = reset_memory(rt, fuzzed_requests(args.resets, args.seed, MEMORY_MIX), args.warmup)
            print(mem.summary())
            result: dict[str, object] = asdict(mem)
        else:
            still = reset_stillness(rt, fuzzed_requests(args.resets, args.seed, STILL_MIX), args.window)
            print(still.summary())
            result = asdict(still)
    if args.json:
        with open(args.json, "w") as f:
            json.dump(result, f, indent=1)
    return 0


if __name__ == "__main__":
    sys.exit(main())
