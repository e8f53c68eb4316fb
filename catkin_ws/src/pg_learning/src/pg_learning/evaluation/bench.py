"""Decision latency: heightmap + target mask in -> decision out (both nets, all rotations, masked argmax, rule).

Modes (all with the same weights and the same heightmaps):
- ``vpg-loop``: VPG-style reference: one rotation at a time, batch 1 (both nets per rotation, as VPG's forward).
- ``batched``: ours: all rotations in one pass per net, rotated inputs shared by both nets. The reference decision.
- ``early-grasp``: grasp net first; the push net runs only when the masked max Q_g does not exceed the threshold.
  Same decision as ``batched`` by construction; its latency is the time of the path taken on each heightmap.
- ``window``: Q maps only of the push region's bounding box (target grown by the push radius), computed from crops
  of the rotated canvases (stride-aligned, + `margin` px of context) so the trunks see what they see in the full map
  there, and -inf elsewhere. With the backbone's exact margin (lite: 88 px) the maps equal the full maps (identical
  decisions); DenseNet-121's receptive field (2071 px) exceeds the map, so its window (default margin 0.1 m) is
  approximate.
- ``window+early``: both speed-ups.
Each mode is timed over `runs` calls (after two warm-up calls) cycling through the heightmaps of the shipped scenes
(ground-truth target masks), the modes interleaved call by call so that changes of machine load hit all alike; the
CPU column (process time, all threads) is less sensitive to other load than wall time. Agreement = % of heightmaps
whose decision (primitive, rotation, row, col) equals ``batched``'s. Every mode decides as the learned policy decides
on its Q maps (LearnedPolicy.act without test-time rules: `pg_policy.decision.decision.decide` over the regions of
`pg_policy.decision.decision.regions`, on the whole heightmap); the modes differ only in how they compute the maps.
"""

from __future__ import annotations

import os
import statistics
import sys
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np
import torch

from pg_core.geometry import PrimitiveSpec, load
from pg_core.heightmap import Heightmap
from pg_core.target_mask import radius_cells
from pg_policy.decision.decision import PUSH_RADIUS_M, Decision, decide, regions
from pg_policy.models.device import check_device
from pg_policy.models.inference import PolicyNets, target_window
from pg_policy.models.nets.registry import BACKBONES
from pg_sim.scenes.scene import list_scenes

VARIANTS = ("lite", "lite-os8", "densenet121")
APPROX_MARGIN_M = 0.1  # window context for backbones without an exact margin
REFERENCE = "batched"
BASELINE = "vpg-loop"


@dataclass(frozen=True)
class Case:
    """One benchmark input: a scene's heightmap and its ground-truth (H, W) bool target mask."""

    name: str
    heightmap: Heightmap
    target: np.ndarray


def scene_cases(scenes: Sequence[str] | None = None) -> list[Case]:
    """Settled shipped scenes (default: all of `pg_sim.scenes.scene.list_scenes()`) -> cases with ground-truth masks.

    Raises ValueError for an unknown scene or a scene whose target is not visible in the heightmap."""
    from pg_sim.world.scene_source import make_world_with_scene  # here: `--cases` runs without the simulator

    cases = []
    for name in scenes or list_scenes():
        with make_world_with_scene(name) as world:
            obs = world.observe()
            target = world.label_heightmap(obs.frame) == world.target_id
        if not target.any():
            raise ValueError(f"scene {name}: the target is not visible in the heightmap")
        cases.append(Case(name, obs.heightmap, target))
    return cases


def save_cases(cases: Sequence[Case], path: str | os.PathLike) -> None:
    """Write cases to one .npz (heightmap arrays, geometry and masks per case) for `load_cases`, so the benchmark
    can run where the simulator is not installed (e.g. a GPU machine)."""
    arrays: dict[str, np.ndarray] = {"names": np.array([c.name for c in cases])}
    for i, c in enumerate(cases):
        hm = c.heightmap
        arrays.update({f"{i}_color": hm.color, f"{i}_height": hm.height, f"{i}_valid": hm.valid,
                       f"{i}_resolution": np.float64(hm.resolution), f"{i}_bounds": np.asarray(hm.bounds),
                       f"{i}_target": c.target})
    np.savez_compressed(path, **arrays)


def load_cases(path: str | os.PathLike) -> list[Case]:
    """Cases written by `save_cases`. Raises ValueError for a file that is not such an archive."""
    try:
        with np.load(path, allow_pickle=False) as z:
            return [Case(str(name), Heightmap(z[f"{i}_color"], z[f"{i}_height"], z[f"{i}_valid"],
                                              float(z[f"{i}_resolution"]), z[f"{i}_bounds"]),
                         z[f"{i}_target"].astype(bool))
                    for i, name in enumerate(z["names"])]
    except (OSError, KeyError, ValueError) as e:
        raise ValueError(f"{path}: not a benchmark cases file written by `pushgrasp bench --save-cases` ({e})") from e


@dataclass
class Decider:
    """Each mode's Q maps for one pair of nets, decided the way the learned policy decides on its Q maps
    (`decide`); `threshold` is the grasp threshold on the masked max Q_g."""

    nets: PolicyNets
    prims: PrimitiveSpec
    threshold: float = 1.8
    margin: int | None = None  # window context (px); None: the nets' exact margin
    early_fired: int = field(default=0, init=False)

    def _decide(self, hm: Heightmap, target: np.ndarray, q: dict[str, np.ndarray]) -> Decision:
        """The learned policy's decision step on full-size Q maps, without test-time rules (LearnedPolicy.act with
        an empty rule list): `decide` over the grasp and push regions the policy decides in. A push map not computed
        yet (early grasp) is stood in for by Q_g: `decide` reads Q_p only when it pushes."""
        grasp, push = regions(target, hm)
        return decide(q["grasp"], q.get("push", q["grasp"]), target, hm, self.prims, self.threshold,
                      push_mask=push, grasp_mask=grasp)

    def _early(self, hm: Heightmap, target: np.ndarray, maps: Callable[[tuple[str, ...]], dict[str, np.ndarray]]
               ) -> Decision:
        """Grasp net first; the push net runs only when `decide` does not grasp on Q_g alone."""
        q = maps(("grasp",))
        d = self._decide(hm, target, q)
        if d.primitive == "grasp":
            self.early_fired += 1
            return d
        q.update(maps(("push",)))
        return self._decide(hm, target, q)

    def batched(self, hm: Heightmap, target: np.ndarray) -> Decision:
        return self._decide(hm, target, self.nets.q_maps(hm, target))

    def vpg_loop(self, hm: Heightmap, target: np.ndarray) -> Decision:
        per_rot = [self.nets.q_maps(hm, target, rotations=[r]) for r in range(self.nets.num_rotations)]
        q = {role: np.concatenate([m[role] for m in per_rot], 0) for role in ("grasp", "push")}
        return self._decide(hm, target, q)

    def early(self, hm: Heightmap, target: np.ndarray) -> Decision:
        return self._early(hm, target, lambda roles: self.nets.q_maps(hm, target, nets=roles))

    def window(self, hm: Heightmap, target: np.ndarray, early: bool = False) -> Decision:
        """Q maps only on the push region's bounding box (target + push radius), -inf elsewhere (as the learned
        policy's q_window option lays them out), decided on the whole heightmap."""
        win = target_window(target, radius_cells(PUSH_RADIUS_M, hm.resolution))
        if win is None:
            raise ValueError("window mode needs a non-empty target mask")
        r0, r1, c0, c1 = win

        def maps(roles: tuple[str, ...]) -> dict[str, np.ndarray]:
            out = {}
            for role, sub in self.nets.q_maps(hm, target, nets=roles, window=win, margin=self.margin).items():
                full = np.full((sub.shape[0], *target.shape), -np.inf, dtype=np.float32)
                full[:, r0:r1, c0:c1] = sub
                out[role] = full
            return out

        return self._early(hm, target, maps) if early else self._decide(hm, target, maps(("grasp", "push")))


MODES: dict[str, Callable[[Decider, Heightmap, np.ndarray], Decision]] = {
    "vpg-loop": Decider.vpg_loop,
    "batched": Decider.batched,
    "early-grasp": Decider.early,
    "window": Decider.window,
    "window+early": lambda d, hm, t: d.window(hm, t, early=True),
}


@dataclass(frozen=True)
class Row:
    variant: str
    mode: str
    median_ms: float  # wall clock
    cpu_ms: float  # median process CPU time (all threads) per decision: less sensitive to other load
    speedup: float  # baseline median / this median (wall clock)
    agree: int  # heightmaps whose decision equals the reference's
    cases: int
    note: str = ""


@dataclass
class BenchResult:
    rows: list[Row]
    runs: int
    threads: int
    cases: list[str]
    threshold: float
    device: str = "cpu"

    def report(self) -> str:
        """A readable table (variant, mode, median ms, speed-up vs the VPG loop, decision agreement %)."""
        head = (f"{'variant':12s} {'mode':13s} {'median ms':>10s} {'cpu ms':>8s} {'vs vpg-loop':>11s} "
                f"{'agreement':>15s}  note")
        load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
        lines = [f"decision latency: {self.runs} runs, {self.threads} torch threads, torch {torch.__version__}, "
                 f"{os.cpu_count()} CPUs (load average {load:.1f}), device {self.device}, grasp threshold "
                 f"{self.threshold}, heightmaps: {len(self.cases)} scenes", head, "-" * len(head)]
        for r in self.rows:
            agree = f"{100.0 * r.agree / r.cases:5.1f}% ({r.agree}/{r.cases})" if r.cases else "-"
            lines.append(f"{r.variant:12s} {r.mode:13s} {r.median_ms:10.1f} {r.cpu_ms:8.0f} {r.speedup:10.2f}x "
                         f"{agree:>15s}  {r.note}".rstrip())
        return "\n".join(lines)


def _key(d: Decision) -> tuple[str, int, int, int]:
    return d.primitive, d.rotation, d.row, d.col


def bench_variant(variant: str, cases: Sequence[Case], runs: int, modes: Sequence[str] = tuple(MODES),
                  threshold: float = 1.8, margin_m: float | None = None, seed: int = 0, goal: str = "mask",
                  optimize: bool = True, rotations: int = 16, device: str = "cpu",
                  log: Callable[[str], None] = lambda s: None) -> list[Row]:
    """Time and compare every mode for one backbone with random weights (seeded); rows in `modes` order.

    Each mode: two warm-up calls, then `runs` timed calls cycling through `cases`, modes interleaved (extra untimed
    calls cover cases not reached when runs < len(cases)). margin_m: window context (m); None = the backbone's exact
    margin, else APPROX_MARGIN_M. optimize: frozen TorchScript nets (`optimize_for_cpu`, as deployed) for every mode.
    device: torch device of the nets; every decision ends with its Q maps copied to the host, so GPU timings include
    the synchronisation. Raises ValueError for an unknown mode or no cases."""
    unknown = [m for m in modes if m not in MODES]
    if unknown or not cases:
        raise ValueError(f"unknown modes {unknown} (known: {list(MODES)})" if unknown else "no heightmaps to run on")
    nets = PolicyNets.random(variant, goal, rotations=rotations, seed=seed, optimize=optimize, device=device)
    res = cases[0].heightmap.resolution
    exact = nets.exact_margin()
    margin = int(round(margin_m / res)) if margin_m is not None else exact if exact >= 0 else int(
        round(APPROX_MARGIN_M / res))
    win_note = f"margin {margin} px, " + ("exact" if 0 <= exact <= margin else "approximate")
    decider = Decider(nets, load().primitives, threshold, margin)
    times: dict[str, list[float]] = {}
    cpu: dict[str, list[float]] = {}
    decisions: dict[str, dict[str, tuple]] = {}
    fired: dict[str, int] = {}
    order = [REFERENCE] + [m for m in modes if m != REFERENCE]
    for mode in order:
        for _ in range(2):  # warm-up: allocator, oneDNN primitives, TorchScript's profiling runs
            MODES[mode](decider, cases[0].heightmap, cases[0].target)
        times[mode], cpu[mode], decisions[mode], fired[mode] = [], [], {}, 0
    for i in range(max(runs, len(cases))):  # modes interleaved: a change of machine load hits them alike
        case = cases[i % len(cases)]
        for mode in order:
            decider.early_fired = 0
            t0, c0 = time.perf_counter(), time.process_time()
            d = MODES[mode](decider, case.heightmap, case.target)
            dt, dc = time.perf_counter() - t0, time.process_time() - c0
            if i < runs:
                times[mode].append(dt * 1000.0)
                cpu[mode].append(dc * 1000.0)
            fired[mode] += decider.early_fired
            decisions[mode].setdefault(case.name, _key(d))
        if i + 1 == runs:
            log(f"{variant}: " + ", ".join(f"{m} {statistics.median(times[m]):.1f} ms" for m in order))
    base = statistics.median(times[BASELINE]) if BASELINE in times else float("nan")
    rows = []
    for mode in modes:
        med = statistics.median(times[mode])
        agree = sum(decisions[mode][c.name] == decisions[REFERENCE][c.name] for c in cases)
        notes = [win_note] if "window" in mode else []
        if "early" in mode:
            notes.append(f"early grasp on {fired[mode]}/{max(runs, len(cases))} calls")
        note = "; ".join(notes)
        rows.append(Row(variant, mode, med, statistics.median(cpu[mode]), base / med, agree, len(cases), note))
    return rows


def run(variants: Sequence[str] = VARIANTS, runs: int = 20, threads: int = 2, scenes: Sequence[str] | None = None,
        modes: Sequence[str] = tuple(MODES), threshold: float = 1.8, margin_m: float | None = None, seed: int = 0,
        goal: str = "mask", optimize: bool = True, verbose: bool = True, device: str = "cpu",
        cases_file: str | None = None) -> BenchResult:
    """The whole benchmark; sets torch.set_num_threads(threads). cases_file: heightmaps from `save_cases` instead of
    the simulator's shipped scenes. device "cuda[:N]": fp32 convolutions and matmuls (TF32 off), so that every mode
    computes the same numbers. Raises ValueError for unknown variants/modes or an unavailable device."""

    bad = [v for v in variants if v not in BACKBONES]
    if bad:
        raise ValueError(f"unknown variants {bad}; known: {sorted(BACKBONES)}")
    if runs < 1 or threads < 1:
        raise ValueError("runs and threads must be >= 1")

    dev = check_device(device)
    if dev.type == "cuda":
        torch.backends.cudnn.allow_tf32 = False
        torch.backends.cuda.matmul.allow_tf32 = False
    torch.set_num_threads(threads)
    cases = load_cases(cases_file) if cases_file else scene_cases(scenes)

    def log(s: str) -> None:
        if verbose:
            print(s, file=sys.stderr, flush=True)

    rows: list[Row] = []
    for variant in variants:
        rows += bench_variant(variant, cases, runs, modes, threshold, margin_m, seed, goal, optimize, device=device,
                              log=log)
    return BenchResult(rows, runs, threads, [c.name for c in cases], threshold, str(dev))
