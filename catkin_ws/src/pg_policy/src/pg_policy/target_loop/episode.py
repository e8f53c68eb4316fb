"""The one episode protocol (DESIGN.md section 8) shared by the ROS call (pg_policy.target_loop.target_loop), the
evaluation trial (pg_learning.evaluation.runner.run_trial) and the training episode (pg_learning.training.collector):
the limits, the counting of actions, the termination reasons, the target memory and the seed convention.

An episode is told each observation (`observe`: the heightmap, the target mask, and in simulation whether the
target body is outside the workspace) and each action's outcome (`record`), and answers whether it is over and why
(`over`, `termination`, `why`). Counting:
  - every decision is an action, refused ones included (they moved nothing but spend one action of the budget);
  - an executed grasp is a grasp attempt; it fails unless it lifted the target (goal-agnostic episodes, in training:
    unless it lifted something);
  - an executed push is a push.
The episode is over at the first of, in this order (TERMINATION_RULES):
  completed (the target grasped; never in goal-agnostic episodes), target_lost (it left the workspace: the target
  memory's evidence, pg_policy.perception.target_memory, or in simulation the ground truth, which also overrules the
  evidence), target_not_found (the search is over: hidden for the memory's `search_limit` observations in a row
  with nothing covering where it was last seen, TargetMemory.not_found; the robot's own evidence, which the ground
  truth does not overrule), refused (`max_refused_in_row` refused actions in a row; the ROS call only), failed_grasps
  (`max_failed_grasps` failed attempts), max_actions (`max_actions` actions).
The loops stop an episode for their own reasons with `stop`: time_budget, cancelled and scene_reset (the ROS call),
error (an exception inside it), target_hidden and scene_empty (training).

Futile pushes: `vet` refuses a push that repeats a push that changed nothing (same rotation, within
target_memory.FUTILE_PUSH_RADIUS_M); the loop records it as a refused action without moving anything. The built-in
policies never propose one (they read the same memory from `obs.search`), so the rule binds only other policies.

Seeds: evaluation seeds start at pg_core.seeds.MIN_EVAL_SEED, training seeds lie below it (`check_eval_seed`).
"""

from __future__ import annotations

import numbers
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from pg_core.heightmap import Heightmap
from pg_core.seeds import MIN_EVAL_SEED, is_eval_seed
from pg_policy.perception.target_memory import SEARCH_LIMIT_EXACT, TargetMemory, TargetSearch

DEFAULT_MAX_ACTIONS = 30  # actions (pushes, grasps and refused ones) per episode
DEFAULT_MAX_FAILED_GRASPS = 5  # failed grasp attempts that end an episode

# termination reasons (TrialRecord.termination, LoopResult.termination)
COMPLETED = "completed"  # the target was grasped
FAILED_GRASPS = "failed_grasps"  # max_failed_grasps grasp attempts failed
MAX_ACTIONS = "max_actions"  # the action budget is spent
TARGET_LOST = "target_lost"  # the target left the workspace
TARGET_NOT_FOUND = "target_not_found"  # the search for a hidden target is over (nothing covers its last-seen place)
ERROR = "error"  # an exception inside the episode (policy, simulator, executor)
TIME_BUDGET = "time_budget"  # ROS call: its wall-clock budget is spent
CANCELLED = "cancelled"  # ROS call: the client cancelled it
REFUSED = "refused"  # ROS call: max_refused_in_row primitives in a row were refused or aborted
SCENE_RESET = "scene_reset"  # ROS call: the scene was replaced under it
TARGET_HIDDEN = "target_hidden"  # training: a goal-conditioned episode ends when its target is not visible
SCENE_EMPTY = "scene_empty"  # training: no object is left
TERMINATIONS = (COMPLETED, FAILED_GRASPS, MAX_ACTIONS, TARGET_LOST, TARGET_NOT_FOUND, ERROR, TIME_BUDGET, CANCELLED,
                REFUSED, SCENE_RESET, TARGET_HIDDEN, SCENE_EMPTY)
FUTILE_PUSH_REFUSAL = "futile push not repeated"  # the message of a push `vet` refuses


@dataclass(frozen=True)
class Limits:
    """When an episode stops besides completion: `max_actions` actions, `max_failed_grasps` failed grasp attempts.
    ValueError naming the field unless both are integers >= 1."""

    max_actions: int = DEFAULT_MAX_ACTIONS
    max_failed_grasps: int = DEFAULT_MAX_FAILED_GRASPS

    def __post_init__(self) -> None:
        for name in ("max_actions", "max_failed_grasps"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, numbers.Integral) or value < 1:
                raise ValueError(f"{name} must be an integer >= 1, got {value!r}")


@dataclass(frozen=True)
class Outcome:
    """One action's outcome as the protocol counts it: `refused`: it moved nothing (refused, or, in the ROS call,
    aborted); `target_grasped`: a grasp lifted the target (goal-agnostic episodes: lifted something); `message`:
    the executor's words."""

    refused: bool = False
    target_grasped: bool = False
    message: str = ""


class Episode:
    """Counts and termination of one episode (module docstring). `target`: the target's name for messages;
    `goal_agnostic`: no target (training's first stage): a lifted object is a successful grasp and never completes
    the episode; `max_refused_in_row`: refused actions in a row that end it (None: never); `memory`: the target
    memory (by default a fresh one whose search ends after `search_limit` observations: SEARCH_LIMIT_EXACT for a
    colour's mask, target_memory.SEARCH_LIMIT_TRACKED for a tracked target, None: never)."""

    def __init__(self, limits: Limits | None = None, target: str = "", goal_agnostic: bool = False,
                 max_refused_in_row: int | None = None, memory: TargetMemory | None = None,
                 search_limit: int | None = SEARCH_LIMIT_EXACT) -> None:
        self.limits = limits or Limits()
        self.target = target
        self.goal_agnostic = goal_agnostic
        self.max_refused_in_row = max_refused_in_row
        self.memory = memory or TargetMemory(search_limit=search_limit)
        self.memory.reset()
        self.actions = self.grasps = self.target_grasps = self.failed_grasps = self.pushes = 0
        self.refused = self.refused_in_row = 0
        self.last_message = ""
        self.lost_why: str | None = None
        self.not_found_why: str | None = None
        self.termination = ""
        self.why = ""

    @property
    def search(self) -> TargetSearch:
        """The target memory's view of the latest observation (what the policy acts on)."""
        return self.memory.search

    # -- what happens ------------------------------------------------------------------------------------------
    def observe(self, hm: Heightmap, target: np.ndarray, truth_outside: bool | None = None) -> TargetSearch:
        """One observation: heightmap `hm` and the target's (H, W) bool mask in it; `truth_outside`: the simulator's
        ground truth that the target body lies outside the workspace box (None where unknown: a real cell). Updates
        the target memory and decides target_lost and target_not_found; returns the TargetSearch for the policy."""
        search = self.memory.see(hm, target, self.actions)
        self.not_found_why = None if self.goal_agnostic else self.memory.not_found()
        evidence = self.memory.lost()
        if truth_outside is None:
            self.lost_why = evidence
        elif truth_outside:
            self.lost_why = (f"{evidence} (confirmed by the simulator)" if evidence
                             else "outside the workspace (simulator ground truth)")
        else:
            self.lost_why = None  # the simulator sees it inside: hidden, searched for
        return search

    def vet(self, decision: Any) -> str | None:
        """The refusal message when `decision` (primitive, rotation, x, y) repeats a push that changed nothing, else
        None (the loop executes it)."""
        if self.search.is_futile_repeat(decision.primitive, decision.rotation, decision.x, decision.y):
            return (f"{FUTILE_PUSH_REFUSAL}: rotation {int(decision.rotation)} at ({decision.x:.3f}, "
                    f"{decision.y:.3f}) changed nothing before")
        return None

    def record(self, decision: Any, outcome: Outcome) -> None:
        """Count one action: `decision` (primitive "grasp" or "push", rotation, x, y in `world` m) and its outcome."""
        self.actions += 1
        self.last_message = outcome.message
        self.memory.acted(decision.primitive, decision.rotation, decision.x, decision.y, not outcome.refused)
        if outcome.refused:
            self.refused += 1
            self.refused_in_row += 1
            return
        self.refused_in_row = 0
        if decision.primitive == "push":
            self.pushes += 1
            return
        self.grasps += 1
        if outcome.target_grasped:
            self.target_grasps += 1
        else:
            self.failed_grasps += 1

    def stop(self, termination: str, why: str) -> None:
        """End the episode for a loop's own reason (module docstring); the first reason given stands."""
        if termination not in TERMINATIONS:
            raise ValueError(f"unknown termination {termination!r} (known: {', '.join(TERMINATIONS)})")
        if not self.termination:
            self.termination, self.why = termination, why

    # -- the verdict -------------------------------------------------------------------------------------------
    def over(self) -> bool:
        """Whether the episode is over; sets `termination` and `why` from the first rule of TERMINATION_RULES that
        holds (a reason given to `stop` stands)."""
        if self.termination:
            return True
        for termination, holds, why in TERMINATION_RULES:
            if holds(self):
                self.termination, self.why = termination, why(self)
                return True
        return False

    @property
    def completed(self) -> bool:
        return self.termination == COMPLETED


def _refused_in_row(e: Episode) -> bool:
    return e.max_refused_in_row is not None and e.refused_in_row >= e.max_refused_in_row


# (termination, when it holds, why): checked in this order after every action and observation
TERMINATION_RULES: tuple[tuple[str, Callable[[Episode], bool], Callable[[Episode], str]], ...] = (
    (COMPLETED, lambda e: e.target_grasps > 0 and not e.goal_agnostic,
     lambda e: f"target '{e.target}' grasped" if e.target else "target grasped"),
    (TARGET_LOST, lambda e: e.lost_why is not None, lambda e: f"target lost: {e.lost_why}"),
    (TARGET_NOT_FOUND, lambda e: e.not_found_why is not None, lambda e: f"target not found: {e.not_found_why}"),
    (REFUSED, _refused_in_row, lambda e: f"{e.refused_in_row} primitives in a row failed, last: {e.last_message}"),
    (FAILED_GRASPS, lambda e: e.failed_grasps >= e.limits.max_failed_grasps,
     lambda e: f"gave up after {e.failed_grasps} failed grasps"),
    (MAX_ACTIONS, lambda e: e.actions >= e.limits.max_actions,
     lambda e: f"action budget of {e.limits.max_actions} spent"),
)


def check_eval_seed(seed: int, allow_train_seeds: bool = False) -> None:
    """ValueError when `seed` is negative, or is a training seed (< MIN_EVAL_SEED) unless explicitly allowed: the
    evaluation scenes could then be training scenes."""
    if seed < 0:
        raise ValueError(f"seed must be >= 0, got {seed}")
    if not is_eval_seed(seed) and not allow_train_seeds:
        raise ValueError(f"evaluation seed {seed} is below {MIN_EVAL_SEED:,}: training uses seeds below that, so the "
                         f"evaluation scenes could be training scenes; use --seed >= {MIN_EVAL_SEED} "
                         "(or --allow-train-seeds to override)")


def check_train_seed(seed: int) -> None:
    """ValueError unless 0 <= `seed` < MIN_EVAL_SEED (training seeds; evaluation seeds are above)."""
    if not 0 <= seed < MIN_EVAL_SEED:
        raise ValueError(f"training seed {seed} must be in [0, {MIN_EVAL_SEED}) (evaluation seeds are above)")
