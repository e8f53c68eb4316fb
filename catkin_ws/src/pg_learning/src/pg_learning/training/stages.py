"""The paper's training stages as a registry: which nets learn, what the goal is, how actions are chosen.

- grasp-agnostic: grasp anything; hindsight relabelling makes whatever was grasped the goal. Grasp net only.
- grasp-goal: a named target per episode ("grasp explores" with epsilon); grasps of other objects are relabelled.
- push: goal-conditioned pushing with the grasp net frozen: up to `max_pushes` pushes then a grasp; grasp early
  once the masked max Q_g exceeds the threshold.
- alternate: both nets learn; the decision rule of test time (grasp if masked max Q_g > threshold, else push).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Stage:
    name: str
    trains: tuple[str, ...]  # nets updated in this stage
    goal_agnostic: bool  # the goal is "any object"
    uses_push: bool  # the push net is evaluated / pushes can happen
    previous: str | None  # the stage whose checkpoint this one starts from


STAGES: dict[str, Stage] = {
    s.name: s
    for s in (
        Stage("grasp-agnostic", ("grasp",), True, False, None),
        Stage("grasp-goal", ("grasp",), False, False, "grasp-agnostic"),
        Stage("push", ("push",), False, True, "grasp-goal"),
        Stage("alternate", ("grasp", "push"), False, True, "push"),
    )
}


def choose_primitive(stage: Stage, grasp_max: float, pushes_in_episode: int, threshold: float,
                     max_pushes: int, pushes_in_row: int = 0, push_budget: int = 0) -> str:
    """grasp or push for this step, before exploration. grasp_max = masked max Q_g of the goal. Push stage: grasp
    after `max_pushes` pushes in the episode; alternate stage with `push_budget` > 0: grasp after that many pushes in
    a row (the learned policy's test-time push budget, pg_policy.policies.registry.LearnedPolicy)."""
    if not stage.uses_push:
        return "grasp"
    if stage.name == "push":
        return "grasp" if grasp_max > threshold or pushes_in_episode >= max_pushes else "push"
    return "grasp" if grasp_max > threshold or 0 < push_budget <= pushes_in_row else "push"


def epsilon(iteration: int, start: float, end: float, decay: int) -> float:
    """Linear decay from start to end over `decay` iterations."""
    if decay <= 0:
        return end
    return float(start + (end - start) * min(iteration / decay, 1.0))


def explore_action(rng: np.random.Generator, region: np.ndarray, rotations: int) -> tuple[int, int, int]:
    """Uniformly random (rotation, row, col) with (row, col) inside `region` (H, W) bool (anywhere if empty)."""
    rows, cols = np.nonzero(region)
    if len(rows) == 0:
        rows, cols = np.nonzero(np.ones_like(region, dtype=bool))
    k = int(rng.integers(len(rows)))
    return int(rng.integers(rotations)), int(rows[k]), int(cols[k])
