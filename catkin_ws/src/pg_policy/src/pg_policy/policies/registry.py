"""Policies the evaluation (and the policy node) can run, by name: a registry of baselines and learned policies.

A policy maps an observation (pg_policy.environment.sim_env.EnvObservation, or anything with `.heightmap` and
`.target`, the
target's palette colour name) to a pg_policy.decision.decision.Decision. It finds the target itself, from the colour
heightmap with pg_core.target_mask (never from the simulator's ground truth). `reset(seed)` starts a new trial
(seeding the policy's own randomness); `q_maps()` returns the Q maps behind the last decision ({"grasp": (R, H, W),
"push": (R, H, W)} float arrays; Q_g after the policy's grasp filter, pg_policy.decision.rules.grasp_filter) for
policies that
have them, else {}. A policy may also keep a `last_note`
string saying why it took its last decision (pg_policy.evaluation.trials logs it with the action).

REGISTRY (name -> factory taking PolicyOptions):
- ``random``: uniformly random primitive, rotation and cell, the cell drawn within the target mask grown by
  ``RANDOM_RADIUS_M`` (any object cell when the target is not visible); seeded by reset(seed).
- ``heuristic``: the geometric rule of pg_policy.policies.heuristic_planner.
- ``grasp-only``: a learned grasp net (TorchScript); always grasps at the argmax of Q_g over the target mask.
- ``learned``: grasp + push nets; pg_policy.decision.decision.decide with the grasp threshold from the grasp model's
metadata.
Learned policies are given models as a directory holding grasp.pt (and push.pt), the layout `pushgrasp export`
writes, or as files (grasp first); see `resolve_models`.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any, Protocol, runtime_checkable

import numpy as np

from pg_core.geometry import Geometry, load
from pg_core.heightmap import Heightmap
from pg_policy.decision.decision import Decision, action_pose
from pg_policy.decision.rerank import rerank
from pg_policy.decision.rules.failed_grasps import DEFAULT_RADIUS_M, FailedGrasps
from pg_policy.decision.rules.futile_pushes import DEFAULT_RADIUS_M as FUTILE_RADIUS_M
from pg_policy.decision.rules.futile_pushes import FutilePushes
from pg_policy.decision.rules.grasp_check import make_grasp_check

RANDOM_RADIUS_M = 0.02
GRASP_FILE = "grasp.pt"
PUSH_FILE = "push.pt"


class UnknownPolicyError(ValueError):
    """A policy name that is neither registered nor a model path; the message lists the registry."""


@runtime_checkable
class Policy(Protocol):
    name: str

    def reset(self, seed: int | None = None) -> None: ...

    def act(self, obs: Any) -> Decision: ...

    def q_maps(self) -> dict[str, np.ndarray]: ...


@dataclass(frozen=True)
class PolicyOptions:
    """models: model files/directories (learned policies); seed: default seed before the first reset; geometry:
    the workspace config (default: pg_core.geometry.load()); device: torch device; grasp_threshold: overrides the
    model metadata's threshold (learned); push_budget: overrides the metadata's push budget (learned: after this
    many pushes in a row it grasps even below the threshold; 0 = no budget); failed_grasp_radius_m (learned): a
    failed grasp's closing axis is not retried within this radius in the same trial
    (pg_policy.decision.rules.failed_grasps;
    None = its DEFAULT_RADIUS_M, 0 = off); futile_push_radius_m (learned): likewise for a push that changed nothing
    around the target (pg_policy.decision.rules.futile_pushes); grasp_filter (grasp-only, learned): a
    pg_policy.decision.rules.grasp_filter spec
    applied to Q_g before the decision (None = the model metadata's thresholds.grasp_filter, else "none");
    grasp_check (learned): a pg_policy.decision.rules.grasp_check name ("jaw": re-rank Q_g's best cells by the
    heuristic's
    jaw-footprint test while the target is visible; "jaw-strict": the same, and push (within the push budget) when
    none passes; "jaw-walls": "jaw-strict" that also demands walls where the pads touch; "none" = no check;
    None = the model metadata's thresholds.grasp_check, else none); edge_guard (learned): re-rank Q_p's best cells
    so that the push does not carry the target out of the workspace (pg_policy.decision.rules.edge_guard; None = the
    model
    metadata's thresholds.edge_guard, else off); push_landing (learned): re-rank Q_p's best cells so that the
    closed fingers do not come down on top of an object (pg_policy.decision.rules.push_landing; None = the model
    metadata's
    thresholds.push_landing, else off)."""

    models: tuple[Path, ...] = ()
    seed: int = 0
    geometry: Geometry | None = None
    device: str = "cpu"
    grasp_threshold: float | None = None
    push_budget: int | None = None
    failed_grasp_radius_m: float | None = None
    futile_push_radius_m: float | None = None
    grasp_filter: str | None = None
    grasp_check: str | None = None
    edge_guard: bool | None = None
    push_landing: bool | None = None
    extra: dict[str, Any] = field(default_factory=dict)


def observed_target(obs: Any) -> np.ndarray:
    """(H, W) bool target mask of the observation's colour heightmap for its target colour name (may be empty)."""
    from pg_core.target_mask import target_mask

    hm: Heightmap = obs.heightmap
    return target_mask(hm.color, hm.valid, obs.target)


class _Base:
    name = "base"

    def __init__(self, opts: PolicyOptions) -> None:
        self.geometry = opts.geometry or load()
        self.prims = self.geometry.primitives
        self.rotations = self.geometry.heightmap.rotations
        self.rng = np.random.default_rng(opts.seed)
        self._q: dict[str, np.ndarray] = {}

    def reset(self, seed: int | None = None) -> None:
        self.rng = np.random.default_rng(seed)
        self._q = {}

    def q_maps(self) -> dict[str, np.ndarray]:
        return dict(self._q)

    def decision(self, hm: Heightmap, primitive: str, rotation: int, row: int, col: int, q: float = float("nan"),
                 grasp_q: float = float("nan")) -> Decision:
        x, y, z, yaw = action_pose(hm, primitive, rotation, row, col, self.prims, self.rotations)
        return Decision(primitive, rotation, row, col, q, yaw, x, y, z, grasp_q)


class RandomPolicy(_Base):
    """Random primitive, rotation, and cell near the target (module docstring)."""

    name = "random"

    def act(self, obs: Any) -> Decision:
        from pg_core.target_mask import dilate_mask

        hm = obs.heightmap
        target = observed_target(obs)
        region = dilate_mask(target, hm.resolution, RANDOM_RADIUS_M) if target.any() else hm.height > 0.008
        cells = np.argwhere(region)
        if len(cells) == 0:
            cells = np.argwhere(np.ones_like(hm.valid, dtype=bool))
        row, col = cells[int(self.rng.integers(len(cells)))]
        primitive = ("grasp", "push")[int(self.rng.integers(2))]
        return self.decision(hm, primitive, int(self.rng.integers(self.rotations)), int(row), int(col))


class HeuristicPolicy(_Base):
    """pg_policy.policies.heuristic_planner's rule; remembers, within a trial, the grasps it tried (a later act() means
    they failed)
    and where the target was last seen."""

    name = "heuristic"

    def __init__(self, opts: PolicyOptions) -> None:
        from pg_policy.policies.heuristic_planner import HeuristicParams, HeuristicPlanner

        super().__init__(opts)
        self.planner = HeuristicPlanner(self.geometry, opts.extra.get("heuristic_params") or HeuristicParams())
        self.failed = FailedGrasps(self.rotations)  # storage only: the planner applies its own repeat_radius
        self.last_seen: np.ndarray | None = None
        self.last_action: Any = None
        self.last_note = ""  # why the last decision was taken (logged by pg_policy.evaluation.trials)
        self.pushes_in_row = 0

    def reset(self, seed: int | None = None) -> None:
        super().reset(seed)
        self.failed.clear()
        self.last_seen, self.last_action, self.last_note = None, None, ""
        self.pushes_in_row = 0

    def act(self, obs: Any) -> Decision:
        hm = obs.heightmap
        target = observed_target(obs)
        if target.sum() >= self.planner.p.min_target_cells:
            rows, cols = np.nonzero(target)
            self.last_seen = np.array([hm.bounds[0, 0] + (cols.mean() + 0.5) * hm.resolution,
                                       hm.bounds[1, 0] + (rows.mean() + 0.5) * hm.resolution])
        act = self.planner.plan(hm, target, self.failed.grasps, self.last_seen, self.rng, self.pushes_in_row)
        self.last_action, self.last_note = act, act.why
        self.pushes_in_row = self.pushes_in_row + 1 if act.primitive == "push" else 0
        d = self.decision(hm, act.primitive, act.rotation, act.row, act.col)
        if act.primitive == "grasp":
            self.failed.add(act.rotation, d.x, d.y)  # a later act() in this trial means it failed
        return d


# -- learned policies ----------------------------------------------------------------------------------------------
def resolve_models(paths: Sequence[str | Path], need_push: bool) -> tuple[Path, Path | None]:
    """(grasp model, push model or None) from a directory holding grasp.pt [+ push.pt] or from files (grasp first).

    Raises FileNotFoundError naming what is missing (push.pt only when `need_push`), ValueError for > 2 paths.
    """
    ps = [Path(p).expanduser() for p in paths]
    if not ps:
        raise FileNotFoundError("no model given: pass a directory with grasp.pt/push.pt or the model file(s)")
    if len(ps) > 2:
        raise ValueError(f"at most two model files (grasp, push), got {len(ps)}")
    if len(ps) == 1 and ps[0].is_dir():
        grasp, push = ps[0] / GRASP_FILE, ps[0] / PUSH_FILE
        if not grasp.is_file():
            raise FileNotFoundError(f"model directory {ps[0]} has no {GRASP_FILE} (write one with `pushgrasp export`)")
        if need_push and not push.is_file():
            raise FileNotFoundError(f"model directory {ps[0]} has no {PUSH_FILE}; the learned policy needs both nets "
                                    "(use --policy grasp-only for a grasp net alone)")
        return grasp, push if push.is_file() else None
    for p in ps:
        if not p.is_file():
            raise FileNotFoundError(f"model file not found: {p}")
    if need_push and len(ps) < 2:
        raise FileNotFoundError("the learned policy needs a push model too: pass grasp.pt and push.pt (or their dir)")
    return ps[0], ps[1] if len(ps) > 1 else None


def _load_nets(grasp: Path, push: Path | None, device: str) -> Any:
    """pg_policy.models.inference.PolicyNets from exported files (the grasp net stands in for a missing push net, whose
    maps are then never asked for). Raises ModelLoadError (a ValueError) for bad files or another geometry."""
    from pg_policy.models.inference import PolicyNets
    from pg_policy.models.model_io import ModelLoadError, load_qnet

    if push is not None:
        return PolicyNets.from_files(grasp, push, device=device)
    net, meta = load_qnet(grasp, map_location=device)
    if meta.get("role") != "grasp":
        raise ModelLoadError(f"{grasp}: exported as the {meta.get('role')!r} net, expected 'grasp'")
    return PolicyNets(net, net, {"grasp": meta, "push": meta}, device)


def metadata_thresholds(metadata: Any) -> dict[str, Any]:
    """The decision parameters stored with a grasp model (metadata "thresholds", pg_policy.models.model_io); {} if
    none."""
    thresholds = metadata.get("thresholds") if isinstance(metadata, dict) else None
    return thresholds if isinstance(thresholds, dict) else {}


def grasp_filter_of(opts: PolicyOptions, metadata: Any) -> Any:
    """The pg_policy.decision.rules.grasp_filter.GraspFilter of `opts.grasp_filter`, else of the grasp model's metadata
    (thresholds.grasp_filter), else none. Raises ValueError for a bad spec."""
    from pg_policy.decision.rules.grasp_filter import GraspFilter

    spec = opts.grasp_filter if opts.grasp_filter is not None else metadata_thresholds(metadata).get("grasp_filter")
    return GraspFilter.parse(spec)


def grasp_check_of(opts: PolicyOptions, metadata: Any, geometry: Geometry) -> Any:
    """The pg_policy.decision.rules.grasp_check of `opts.grasp_check`, else of the grasp model's metadata
    (thresholds.grasp_check),
    else none (None). Raises ValueError for an unknown name."""
    name = opts.grasp_check if opts.grasp_check is not None else metadata_thresholds(metadata).get("grasp_check")
    return make_grasp_check(name, geometry)


def edge_guard_of(opts: PolicyOptions, metadata: Any, geometry: Geometry) -> Any:
    """A pg_policy.decision.rules.edge_guard.EdgeGuard when `opts.edge_guard` (else the grasp model's
    thresholds.edge_guard) is
    true, else None."""
    from pg_policy.decision.rules.edge_guard import EdgeGuard

    on = opts.edge_guard if opts.edge_guard is not None else bool(metadata_thresholds(metadata).get("edge_guard"))
    return EdgeGuard(geometry) if on else None


def push_landing_of(opts: PolicyOptions, metadata: Any, geometry: Geometry) -> Any:
    """A pg_policy.decision.rules.push_landing.LandingGuard when `opts.push_landing` (else the grasp model's
    thresholds.push_landing) is true, else None."""
    from pg_policy.decision.rules.push_landing import LandingGuard

    on = opts.push_landing if opts.push_landing is not None else \
        bool(metadata_thresholds(metadata).get("push_landing"))
    return LandingGuard(geometry) if on else None


def _goal_or_all(obs: Any) -> tuple[np.ndarray, bool]:
    """(the target mask, True) when the target is visible; else (every object cell, False): goal-agnostic, to
    uncover it."""
    from pg_core.target_mask import MIN_VISIBLE_CELLS

    target = observed_target(obs)
    if target.sum() >= MIN_VISIBLE_CELLS:
        return target, True
    objects = obs.heightmap.height > 0.008
    return (objects if objects.any() else np.ones_like(target)), False


class GraspOnlyPolicy(_Base):
    """Always grasps at the argmax of the (filtered: `grasp_filter_of`) Q_g over the target mask (all objects when
    the target is not visible)."""

    name = "grasp-only"

    def __init__(self, opts: PolicyOptions) -> None:
        super().__init__(opts)
        grasp, _ = resolve_models(opts.models, need_push=False)
        self.model_paths: tuple[Path, ...] = (grasp,)
        self.nets = _load_nets(grasp, None, opts.device)
        self.grasp_filter = grasp_filter_of(opts, self.nets.metadata["grasp"])

    def act(self, obs: Any) -> Decision:
        from pg_policy.decision.decision import masked_argmax

        hm = obs.heightmap
        mask, _ = _goal_or_all(obs)
        q = self.grasp_filter.apply(self.nets.q_maps(hm, mask, nets=("grasp",))["grasp"])
        self._q = {"grasp": q}
        r, row, col, value = masked_argmax(q, mask & hm.valid if (mask & hm.valid).any() else mask)
        return self.decision(hm, "grasp", r, row, col, value, value)


def threshold_from_metadata(metadata: Any) -> float:
    """The grasp threshold stored with a grasp model (metadata "thresholds" -> "grasp_q", pg_policy.models.model_io);
    ValueError when absent."""
    thresholds = metadata_thresholds(metadata)
    if "grasp_q" not in thresholds:
        raise ValueError("the grasp model's metadata holds no thresholds.grasp_q; pass --grasp-threshold")
    return float(thresholds["grasp_q"])


class LearnedPolicy(_Base):
    """Grasp and push nets + pg_policy.decision.decision.decide (grasp if masked max Q_g > threshold, else push); with
    a push
    budget B > 0 (model metadata thresholds.push_budget or PolicyOptions.push_budget) it grasps after B pushes in a
    row whatever Q_g says, as the paper's push stage does in training; a grasp that failed is not retried at the same
    place and closing axis within the trial (pg_policy.decision.rules.failed_grasps), nor a push that changed nothing
    around the
    target at the same place and direction (pg_policy.decision.rules.futile_pushes); Q_g passes through the grasp filter
    (`grasp_filter_of`, pg_policy.decision.rules.grasp_filter) before the decision; the grasp check re-ranks Q_g and
    may ask for a
    push (pg_policy.decision.rules.grasp_check), and the push guards re-rank Q_p
    (pg_policy.decision.rules.push_landing, then
    pg_policy.decision.rules.edge_guard). All are deviations at test time, each switched by the model metadata or
    PolicyOptions:
    see docs/ARCHITECTURE.md."""

    name = "learned"

    def __init__(self, opts: PolicyOptions) -> None:
        super().__init__(opts)
        grasp, push = resolve_models(opts.models, need_push=True)
        self.model_paths = (grasp, push)
        self.nets = _load_nets(grasp, push, opts.device)
        self.threshold = (opts.grasp_threshold if opts.grasp_threshold is not None
                          else threshold_from_metadata(self.nets.metadata["grasp"]))
        budget = opts.push_budget if opts.push_budget is not None else \
            metadata_thresholds(self.nets.metadata["grasp"]).get("push_budget", 0)
        if int(budget) < 0:
            raise ValueError(f"push budget must be >= 0 (0 = none), got {budget}")
        self.push_budget = int(budget)
        self.pushes_in_row = 0
        radius = DEFAULT_RADIUS_M if opts.failed_grasp_radius_m is None else opts.failed_grasp_radius_m
        self.failed = FailedGrasps(self.rotations, radius)
        radius = FUTILE_RADIUS_M if opts.futile_push_radius_m is None else opts.futile_push_radius_m
        self.futile = FutilePushes(self.rotations, radius)
        self.last_seen: tuple[Heightmap, np.ndarray] | None = None  # the heightmap and mask the last decision used
        self.grasp_filter = grasp_filter_of(opts, self.nets.metadata["grasp"])
        self.grasp_check = grasp_check_of(opts, self.nets.metadata["grasp"], self.geometry)
        self.edge_guard = edge_guard_of(opts, self.nets.metadata["grasp"], self.geometry)
        self.push_landing = push_landing_of(opts, self.nets.metadata["grasp"], self.geometry)
        self.last: Decision | None = None

    def reset(self, seed: int | None = None) -> None:
        super().reset(seed)
        self.pushes_in_row = 0
        self.failed.clear()
        self.futile.clear()
        self.last, self.last_seen = None, None

    def act(self, obs: Any) -> Decision:
        from pg_policy.decision.decision import decide, grasp_region, push_region

        hm = obs.heightmap
        mask, visible = _goal_or_all(obs)
        if self.last is not None and self.last.primitive == "grasp":  # asked again: that grasp missed the target
            self.failed.add(self.last.rotation, self.last.x, self.last.y)
        elif self.last is not None and self.last_seen is not None:  # the last push: did it change anything?
            before, target_before = self.last_seen
            self.futile.observe(self.last.rotation, self.last.x, self.last.y, before, hm, target_before)
        q = self.nets.q_maps(hm, mask)
        self._q = {"grasp": self.grasp_filter.apply(q["grasp"]), "push": q["push"]}
        spent = 0 < self.push_budget <= self.pushes_in_row
        q_grasp = self.failed.suppress(self._q["grasp"], hm)
        threshold, self.last_note = (-math.inf if spent else self.threshold), ""
        if self.grasp_check is not None and visible:
            q_grasp = self.grasp_check.apply(q_grasp, hm, grasp_region(mask, hm.resolution), mask)
            if self.grasp_check.push_instead and not spent:
                threshold, self.last_note = math.inf, "no grasp passes the jaw check: push"
        q_push = self.futile.suppress(self._q["push"], hm)
        tests, top_k = [], max([g.top_k for g in (self.push_landing, self.edge_guard) if g is not None], default=1)
        if visible and self.push_landing is not None:
            tests.append(self.push_landing.candidate_test(hm))
        if visible and self.edge_guard is not None and (edge := self.edge_guard.candidate_test(hm, mask)) is not None:
            tests.append(edge)
        if tests:  # a push candidate must pass every push guard
            q_push, _ = rerank(q_push, push_region(mask, hm.resolution),
                               lambda r, row, col: all(t(r, row, col) for t in tests), top_k)
        d = decide(q_grasp, q_push, mask, hm, self.prims, threshold)
        self.pushes_in_row = self.pushes_in_row + 1 if d.primitive == "push" else 0
        self.last, self.last_seen = d, (hm, mask)
        return d


REGISTRY: dict[str, Callable[[PolicyOptions], Policy]] = {
    "random": RandomPolicy,
    "heuristic": HeuristicPolicy,
    "grasp-only": GraspOnlyPolicy,
    "learned": LearnedPolicy,
}
NEEDS_MODEL = ("grasp-only", "learned")
SHIPPED_MODELS = Path(__file__).resolve().parents[3] / "models"  # catkin_ws/src/pg_policy/models


def make_policy(name_or_path: str, opts: PolicyOptions | None = None) -> Policy:
    """A policy by registry name, or `learned` / `grasp-only` from a model path given as the name (a directory with
    grasp.pt and push.pt -> learned, with grasp.pt only or a single file -> grasp-only), or from the name of a
    folder of SHIPPED_MODELS (e.g. "lite"; a path that exists wins).

    Raises UnknownPolicyError (a ValueError) listing the registry, FileNotFoundError for missing model files.
    """
    opts = opts or PolicyOptions()
    if name_or_path in REGISTRY:
        if name_or_path in NEEDS_MODEL and not opts.models:
            raise FileNotFoundError(f"policy {name_or_path!r} needs a model: --model DIR (with {GRASP_FILE}"
                                    f"{', ' + PUSH_FILE if name_or_path == 'learned' else ''}) or model file(s)")
        return REGISTRY[name_or_path](opts)
    path = Path(name_or_path).expanduser()
    if not path.exists() and (SHIPPED_MODELS / name_or_path).is_dir():
        path = SHIPPED_MODELS / name_or_path  # a shipped model by folder name, e.g. "lite"
    if path.is_dir() or path.suffix == ".pt" or path.exists():
        kind = "learned" if (path.is_dir() and (path / PUSH_FILE).is_file()) else "grasp-only"
        if not path.exists():
            raise FileNotFoundError(f"model file not found: {path}")
        return REGISTRY[kind](replace(opts, models=(path, *opts.models)))
    raise UnknownPolicyError(f"unknown policy {name_or_path!r}: not a registered policy "
                             f"({', '.join(REGISTRY)}) nor a model file or directory")
