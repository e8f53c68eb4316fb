"""`pushgrasp bench --policy NAME`: a policy's decision end to end, as the policy node and `pushgrasp eval` run it.

One call of `policy.act(observation)`: the observation (heightmap + the target's colour name) in, the decision out.
For the learned policy the call is broken down by stage (LearnedPolicy.last_timings): perceive (target mask and
regions), nets (both Q maps, all rotations), each rule of the model's pipeline (its map adjustment and its candidate
tests) and the re-rank walk, decide (threshold and masked argmax). The observations are the first views of the given
shipped scenes, rendered by the simulator; the policy is reset before every call, so each call is a trial's first
decision. Calls cycle through the scenes; the medians are over all calls. Every call on an observation must give
the decision of the first call on it (`decisions_stable`). `overrides` sets policy options (e.g. q_window off: the
full Q maps), so that two runs can be compared decision by decision (`same_decisions`).
"""

from __future__ import annotations

import os
import platform
import statistics
import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

DEFAULT_SCENES = ("packed/case01", "packed/case05", "packed/case09", "household/case12")


@dataclass
class PolicyBench:
    """Figures of one policy: total and per-stage seconds per call (lists over calls), load and versions."""

    policy: str  # with the options set, e.g. "lite (q_window=False)"
    threads: int
    scenes: list[str]
    total_s: list[float] = field(default_factory=list)
    stages_s: dict[str, list[float]] = field(default_factory=dict)
    decisions_stable: bool = True
    decisions: dict[str, str] = field(default_factory=dict)
    load_before: float = 0.0
    load_after: float = 0.0
    torch_version: str = ""

    def median_ms(self) -> float:
        return 1000 * statistics.median(self.total_s)

    def report(self) -> str:
        p90 = 1000 * float(np.percentile(self.total_s, 90))
        lines = [f"policy `{self.policy}` end to end (act: observation in, decision out): median "
                 f"{self.median_ms():.1f} ms, p90 {p90:.1f} ms over {len(self.total_s)} calls on "
                 f"{', '.join(self.scenes)}",
                 f"torch {self.torch_version}, {self.threads} torch threads, {os.cpu_count()} cores "
                 f"({platform.processor() or platform.machine()}), load average {self.load_before:.2f} before, "
                 f"{self.load_after:.2f} after; decisions stable across calls: "
                 f"{'yes' if self.decisions_stable else 'NO'}"]
        if self.stages_s:
            lines += ["", "| Stage | Median ms | Share of the median total |", "|---|---|---|"]
            total = self.median_ms()
            for stage, values in self.stages_s.items():
                ms = 1000 * statistics.median(values)
                lines.append(f"| {stage} | {ms:.1f} | {100 * ms / total:.0f} % |")
        lines += ["", "| Scene | Decision |", "|---|---|"]
        lines += [f"| {scene} | {d} |" for scene, d in self.decisions.items()]
        return "\n".join(lines)


def _observations(scenes: Sequence[str]) -> list[tuple[str, Any]]:
    """(scene, first observation) of each shipped scene, rendered by the simulator (seed 0)."""
    from pg_learning.environment.sim_env import SimEnv

    with SimEnv() as env:
        return [(scene, env.reset(scene, seed=0)) for scene in scenes]


def _key(d: Any) -> str:
    return f"{d.primitive} r{d.rotation} ({d.row}, {d.col})"


def same_decisions(a: PolicyBench, b: PolicyBench) -> bool:
    """Whether two runs decided alike on every scene they share (primitive, rotation and cell)."""
    shared = set(a.decisions) & set(b.decisions)
    return bool(shared) and all(a.decisions[s] == b.decisions[s] for s in shared)


def bench_policy(policy: str = "lite", scenes: Sequence[str] = DEFAULT_SCENES, runs: int = 10, threads: int = 2,
                 verbose: bool = True, overrides: dict[str, Any] | None = None) -> PolicyBench:
    """Time `runs` rounds of act() over the first observations of `scenes` (module docstring), the policy made
    with the option values `overrides`. Raises ValueError for an unknown policy, scene or option, runs < 1 or
    threads < 1."""
    import torch

    from pg_policy.policies.policy import PolicyOptions
    from pg_policy.policies.registry import make_policy

    if runs < 1 or threads < 1:
        raise ValueError(f"runs and threads must be >= 1, got {runs} and {threads}")
    torch.set_num_threads(threads)
    pol = make_policy(policy, PolicyOptions(overrides=dict(overrides or {})))
    obs = _observations(scenes)
    label = policy + (f" ({', '.join(f'{k}={v}' for k, v in overrides.items())})" if overrides else "")
    result = PolicyBench(label, threads, list(scenes), torch_version=torch.__version__,
                         load_before=os.getloadavg()[0])
    for _ in range(2):  # warm-up: allocator, oneDNN primitives, lazy imports
        for _, o in obs:
            pol.reset(0)
            pol.act(o)
    for i in range(runs):
        for scene, o in obs:
            pol.reset(0)
            start = time.perf_counter()
            d = pol.act(o)
            result.total_s.append(time.perf_counter() - start)
            for stage, s in getattr(pol, "last_timings", {}).items():
                result.stages_s.setdefault(stage, []).append(s)
            key = _key(d)
            result.decisions_stable &= result.decisions.setdefault(scene, key) == key
        if verbose:
            print(f"[bench] policy {label}: round {i + 1}/{runs}, median so far {result.median_ms():.1f} ms",
                  flush=True)
    result.load_after = os.getloadavg()[0]
    return result
