"""The metrics of DESIGN.md section 8 over episode records (pg_policy.target_loop.records.TrialRecord): C, GS and MN,
each reported as mean +- standard error over trials. `pushgrasp eval` (pg_learning.evaluation) reports them per
scene, the bag replay (pg_policy.ros.bag_replay) over a recorded experiment's grasp_target calls.

Per-trial quantities and the per-scene metrics:
  - C  (completion): c_i = 1 if trial i completed else 0, averaged over all trials of the scene.
  - GS (grasp success): g_i = target grasps_i / grasp attempts_i (0 or 1/attempts, since a trial stops at its first
    target grasp), averaged over the trials with at least one grasp attempt (undefined when there are none).
  - MN (motion number): m_i = pushes_i, averaged over the COMPLETED trials only (undefined when none completed).
Secondary figures kept in the records: ``gs_completed`` (g_i averaged over completed trials only: the "grasp success
per clearance" of Xu et al.'s evaluate.py), ``actions_completed`` (all actions per completed trial: the "motion
number" as Xu et al.'s evaluate.py counts it), ``refused`` (refused actions per trial), ``errors`` and ``lost`` (the
fractions of trials that ended in an error and whose target left the workspace).
Target tracking (episodes whose target is named by a point or a mask, followed by a tracker; `tracking`): over
the steps whose action record's ``target`` holds ``iou`` (the tracked mask against the simulator's ground truth of
that observation) and whose ground truth shows the target (``truth_cells`` >= MIN_VISIBLE_CELLS), the fraction
with IoU >= IOU_OK; over the executed grasps, the fraction that held another object (TrialRecord.wrong_grasps).
Both are pooled counts (steps, grasps), not means over trials.
Standard error of n values v_1..v_n with mean m: se = sqrt(sum_i (v_i - m)^2 / (n - 1)) / sqrt(n) (sample standard
deviation over sqrt(n)); undefined (None) for n < 2.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass
from typing import TypeVar

import numpy as np

from pg_core.target_mask import MIN_VISIBLE_CELLS
from pg_policy.target_loop.episode import ERROR, TARGET_LOST, TARGET_NOT_FOUND
from pg_policy.target_loop.records import TrialRecord

T = TypeVar("T")


@dataclass(frozen=True)
class Stat:
    """Mean and standard error of n per-trial values (mean None for n = 0, se None for n < 2)."""

    mean: float | None
    se: float | None
    n: int


def mean_se(values: Iterable[float]) -> Stat:
    """Mean and standard error sqrt(sum (v - mean)^2 / (n - 1)) / sqrt(n) of the values (see module docstring)."""
    v = np.asarray(list(values), dtype=np.float64)
    n = int(v.size)
    if n == 0:
        return Stat(None, None, 0)
    mean = float(v.mean())
    se = float(v.std(ddof=1) / math.sqrt(n)) if n > 1 else None
    return Stat(mean, se, n)


def scene_metrics(trials: Sequence[TrialRecord]) -> dict[str, Stat]:
    """C, GS, MN (and the secondary figures) over the given trials, per the definitions of the module docstring."""
    done = [t for t in trials if t.completed]
    return {
        "C": mean_se(1.0 if t.completed else 0.0 for t in trials),
        "GS": mean_se(t.grasp_success for t in trials if t.grasp_success is not None),
        "MN": mean_se(t.pushes for t in done),
        "gs_completed": mean_se(t.grasp_success for t in done if t.grasp_success is not None),
        "actions_completed": mean_se(t.n_actions for t in done),
        "refused": mean_se(t.refused for t in trials),
        "errors": mean_se(1.0 if t.termination == ERROR else 0.0 for t in trials),  # mean x n = error trials
        "lost": mean_se(1.0 if t.termination == TARGET_LOST else 0.0 for t in trials),  # mean x n = lost targets
        "not_found": mean_se(1.0 if t.termination == TARGET_NOT_FOUND else 0.0 for t in trials),  # searches in vain
    }


def by_scene(trials: Sequence[TrialRecord], of: Callable[[Sequence[TrialRecord]], T]) -> dict[str, T]:
    """`of` applied to each scene's trials in first-seen scene order, plus "all" over every trial when there are
    several scenes."""
    scenes: dict[str, list[TrialRecord]] = {}
    for t in trials:
        scenes.setdefault(t.scene, []).append(t)
    out = {name: of(ts) for name, ts in scenes.items()}
    if len(scenes) > 1:
        out["all"] = of(trials)
    return out


def summarize(trials: Sequence[TrialRecord]) -> dict[str, dict[str, Stat]]:
    """Per-scene metrics in first-seen scene order, plus "all" over every trial when there are several scenes."""
    return by_scene(trials, scene_metrics)


IOU_OK = 0.7  # a tracked mask with at least this IoU against the ground truth follows the right object


@dataclass(frozen=True)
class Tracking:
    """Pooled tracking counts of some trials (module docstring): `steps` with the target visible in ground truth
    and an IoU recorded, `iou_ok` of them with IoU >= IOU_OK, `unsure` steps the tracker doubted (of all steps with
    an IoU recorded, `tracked`), executed `grasps` and the `wrong_grasps` among them."""

    steps: int
    iou_ok: int
    tracked: int
    unsure: int
    grasps: int
    wrong_grasps: int

    @property
    def iou_ok_fraction(self) -> float | None:
        """iou_ok / steps; None without such steps."""
        return self.iou_ok / self.steps if self.steps else None

    @property
    def wrong_fraction(self) -> float | None:
        """wrong_grasps / grasps; None without grasps."""
        return self.wrong_grasps / self.grasps if self.grasps else None


def tracking(trials: Sequence[TrialRecord]) -> Tracking:
    """The pooled tracking counts of `trials` (module docstring)."""
    steps = iou_ok = tracked = unsure = 0
    for t in trials:
        for a in t.actions:
            view = a.get("target")
            if not isinstance(view, dict) or "iou" not in view:
                continue
            tracked += 1
            unsure += bool(view.get("unsure"))
            if int(view.get("truth_cells") or 0) >= MIN_VISIBLE_CELLS and view["iou"] is not None:
                steps += 1
                iou_ok += float(view["iou"]) >= IOU_OK
    return Tracking(steps, iou_ok, tracked, unsure, sum(t.grasps for t in trials),
                    sum(t.wrong_grasps for t in trials))


def tracking_by_scene(trials: Sequence[TrialRecord]) -> dict[str, Tracking]:
    """`tracking` per scene in first-seen scene order, plus "all" when there are several scenes (as summarize)."""
    return by_scene(trials, tracking)


def fmt(stat: Stat, scale: float = 1.0, digits: int = 1) -> str:
    """'mean ± se' with the given scale and decimals; 'n/a' for no values, 'mean ± n/a' for a single value."""
    if stat.mean is None:
        return "n/a"
    se = "n/a" if stat.se is None else f"{stat.se * scale:.{digits}f}"
    return f"{stat.mean * scale:.{digits}f} ± {se}"
