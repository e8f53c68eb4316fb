"""What every policy is: the Policy protocol, the options policies are made with, and their shared base.

A policy maps an observation (pg_learning.environment.sim_env.EnvObservation, or anything with `.heightmap`, a
pg_core.heightmap.Heightmap, and `.target`, the target's palette colour name) to a
pg_policy.decision.decision.Decision. It finds the target itself, from the colour heightmap with pg_core.target_mask
(never from the simulator's ground truth). `reset(seed)` starts a new trial (seeding the policy's own randomness);
`q_maps()` returns the Q maps behind the last decision ({"grasp": (R, H, W), "push": (R, H, W)} float arrays, after
the "filter" rules) for policies that have them, else {}. A policy may also keep a `last_note` string saying why it
took its last decision (the evaluation logs it with the action). Within an episode (a ROS call, an evaluation trial)
the observation also carries `.search`, the episode's target memory (pg_policy.perception.target_memory.TargetSearch:
where the target was last seen, what covers that place while it is hidden, the pushes that changed nothing), which a
policy should honour: search where the target was last seen (`goal_of`), never repeat a futile push (the episode
refuses it). Outside an episode (/pg/infer, bag replays) `.search` is absent or None. docs/PLUGINS.md is this
contract for third-party policies.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Protocol, runtime_checkable

import numpy as np

from pg_core.geometry import Geometry, load
from pg_core.heightmap import OBJECT_HEIGHT_M, Heightmap
from pg_core.target_mask import MIN_VISIBLE_CELLS, target_mask
from pg_policy.decision.decision import Decision, action_pose


@runtime_checkable
class Policy(Protocol):
    name: str

    def reset(self, seed: int | None = None) -> None: ...

    def act(self, obs: Any) -> Decision: ...

    def q_maps(self) -> dict[str, np.ndarray]: ...


@dataclass(frozen=True)
class PolicyOptions:
    """models: model files/directories (learned policies); seed: default seed before the first reset; geometry: the
    workspace config (default: pg_core.geometry.load()); device: torch device; overrides: values of the declared
    options (pg_policy.policies.options: grasp_threshold, push_budget, rules and the rules' switches) by name, an
    absent or None value meaning the model's own; extra: policy-specific objects (e.g. heuristic_params)."""

    models: tuple[Path, ...] = ()
    seed: int = 0
    geometry: Geometry | None = None
    device: str = "cpu"
    overrides: Mapping[str, Any] = field(default_factory=dict)
    extra: dict[str, Any] = field(default_factory=dict)

    def get(self, name: str) -> Any:
        """The override of option `name`, None when unset."""
        return self.overrides.get(name)


def observed_target(obs: Any) -> np.ndarray:
    """(H, W) bool target mask of the observation (may be empty): the mask the loop tracked (`obs.mask`, a point or
    mask request) when it has one, else the cells of the heightmap of the target's colour name."""
    mask = getattr(obs, "mask", None)
    if mask is not None:
        return np.asarray(mask, dtype=bool)
    hm: Heightmap = obs.heightmap
    return target_mask(hm.color, hm.valid, obs.target)


@dataclass(frozen=True)
class Goal:
    """What a policy acts on: `mask` ((H, W) bool), whether it is the visible target, and, while the target is
    hidden, `note` (what the policy does about it: searching where it was last seen, or every object)."""

    mask: np.ndarray
    visible: bool
    note: str = ""


def goal_of(obs: Any, min_cells: int = MIN_VISIBLE_CELLS) -> Goal:
    """The target mask when the target is visible (at least `min_cells` cells). While it is hidden: the search goal
    of the episode's target memory (`obs.search`, pg_policy.perception.target_memory.TargetSearch.goal: the object
    cells covering the place the target was last seen), else every object cell (goal-agnostic, to uncover it; every
    cell when nothing stands on the table)."""
    target = observed_target(obs)
    if target.sum() >= min_cells:
        return Goal(target, True)
    search = getattr(obs, "search", None)
    if search is not None:
        goal = search.goal(obs.heightmap, OBJECT_HEIGHT_M)
        if goal is not None:
            return Goal(goal, False, search.note(True))
    objects = obs.heightmap.height > OBJECT_HEIGHT_M
    note = "target hidden" if search is None else search.note(False)
    return Goal(objects if objects.any() else np.ones_like(target), False, note)


def goal_or_all(obs: Any, min_cells: int = MIN_VISIBLE_CELLS) -> tuple[np.ndarray, bool]:
    """(goal mask, target visible) of goal_of."""
    goal = goal_of(obs, min_cells)
    return goal.mask, goal.visible


class PolicyBase:
    """Geometry, seeded randomness, the last Q maps and Decision construction for the built-in policies."""

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
