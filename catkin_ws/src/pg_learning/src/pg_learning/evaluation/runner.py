"""The evaluation runner behind `pushgrasp eval`: the trials of the protocol of DESIGN.md section 8, in this process or
on Ray actors, every one through the same protocol, each in a fresh simulator, so the records do not depend on where
they ran. A trial is one episode of the protocol shared with the ROS call and training
(pg_policy.target_loop.episode): reset the scene (seeded), then ask the policy for one decision at a time and
execute it, until
  - the target is grasped (the trial is *completed*),
  - the target has left the workspace (``target_lost``: the target memory's evidence, confirmed, or overruled, by
    the simulator's ground truth, SimEnv.target_outside),
  - the search for a hidden target is over (``target_not_found``: hidden with nothing over its last-seen place for
    target_memory.SEARCH_LIMIT_EXACT observations in a row, SEARCH_LIMIT_TRACKED for a point or mask target),
  - ``max_failed_grasps`` (5) grasp attempts have failed, or
  - ``max_actions`` (30) actions have been taken.
Every decision the policy returns counts as an action, refused ones included (they are logged with the refusal
message). An executed grasp is a *grasp attempt*; it *fails* unless the target is the object held after lifting (a
wrong object held also fails, and the simulator removes that object). An executed push is a *push*. A refused
decision is neither an attempt nor a push: it moved nothing, but it spends one action of the budget. A push that
repeats a push that changed nothing (same rotation, same place) is refused by the protocol without moving.
The policy gets each observation with the episode's target memory as ``obs.search`` (where the target was last
seen, what covers that place while it is hidden, the futile pushes).

Naming the target (`EvalPlan.target_by`, pg_learning.evaluation.target_by): by its colour (default), or by a point
or a mask taken from the simulator's ground truth of the first view only; then every observation's target mask
comes from the trial's tracker, goes to the episode and to the policy (``PolicyObservation.mask``), and each
action's record keeps its IoU against that observation's ground truth and the tracker's doubt (``target``: iou,
truth_cells, unsure, why). Completion stays by body id: only a grasp that holds the object pointed at completes a
trial; a grasp holding another object fails (TrialRecord.wrong_grasps counts them). `EvalPlan.colours` paints the
scenes so that colours repeat (pg_sim.world.recolour); a colour then names no single object, so ``colour`` is
refused with such scenes.

The metrics over the records, C, GS and MN (each reported as mean +- standard error over trials), are defined in
pg_policy.target_loop.metrics; the record of a trial is pg_policy.target_loop.records.TrialRecord.

Seeds: trial i (0-based) of every scene uses seed ``seed + i``: it seeds the random scene (``random-N``), the pose
jitter of fixed scenes, and the policy's own randomness (``policy.reset(seed)``), so a run is reproducible from
``seed`` alone (every trial runs in a fresh simulator, see ``run_plan``). Evaluation seeds must be disjoint from
training seeds: training uses seeds below ``MIN_EVAL_SEED`` (pg_core.seeds; ``check_seed``).

Fixed scenes (packed, household, files) are deterministic in PyBullet, so repeated trials of a deterministic policy
would be copies of each other. Each trial therefore places the whole scene with a small seeded rigid motion
(``jitter_xy`` m uniform translation, ``jitter_yaw`` rad uniform rotation about the scene's centroid; the objects'
relative poses, i.e. the test case itself, are unchanged). ``jitter_xy = jitter_yaw = 0`` evaluates the exact file.

Errors: an Exception raised while preparing or running a trial (building the scene, making the simulator, the policy's
reset/act, the simulator's reset/step/observe) ends that trial as a failure with termination "error" and its reason
(pg_learning.evaluation.errors); the run goes on. Such a trial is not completed (it counts in C as a failure); its
grasps and pushes before the error count as usual. ``errors`` (per trial: 1 if it ended in an error) is reported
beside the metrics.

Where trials run: `run_jobs` here, in this process; pg_learning.evaluation.trial_workers (`run_trials`) chooses
between this process and Ray actors. Heavy modules (pybullet, torch, the policies) are imported where they are used.
"""

from __future__ import annotations

import logging
import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, fields, is_dataclass, replace
from typing import Any, Protocol

import numpy as np

from pg_core.seeds import MIN_EVAL_SEED
from pg_core.target_mask import target_mask
from pg_learning.evaluation.errors import ERROR, mark_error
from pg_learning.evaluation.target_by import COLOUR, TrialTarget, check_target_by
from pg_policy.models.click_segmentation import DEFAULT_SEGMENTER
from pg_policy.perception.target_memory import search_limit
from pg_policy.target_loop.episode import Episode, Limits, Outcome
from pg_policy.target_loop.episode import check_eval_seed as check_seed
from pg_policy.target_loop.loop_types import PolicyObservation
from pg_policy.target_loop.records import TrialRecord, plain
from pg_sim.scenes.scene import find_scene, list_scenes, load_scene
from pg_sim.world.recolour import UNIQUE, check_mode
from pg_sim.world.scene_families import GENERATED
from pg_sim.world.sensor_model import PERFECT
from pg_sim.world.sim_mode import DEFAULT_SIM_MODE

__all__ = ["MIN_EVAL_SEED", "Limits", "check_seed"]  # re-exported: the protocol's seed convention and limits
DEFAULT_SEED = MIN_EVAL_SEED
DEFAULT_JITTER_XY = 0.01  # m
DEFAULT_JITTER_YAW = math.radians(11.25)  # half of one of the 16 rotation steps
FAMILIES = ("packed", "household")
log = logging.getLogger(__name__)


class EvalEnv(Protocol):
    """What a trial needs of an environment (pg_learning.environment.sim_env.SimEnv satisfies it)."""

    def reset(self, scene: Any, seed: int = 0) -> Any: ...

    def step(self, primitive: str, x: float, y: float, z: float, yaw: float) -> Any: ...

    def observe(self) -> Any: ...


class EvalPolicy(Protocol):
    name: str

    def reset(self, seed: int | None = None) -> None: ...

    def act(self, obs: Any) -> Any: ...


def run_trial(env: EvalEnv, policy: EvalPolicy, scene: Any, seed: int, limits: Limits | None = None,
              scene_name: str | None = None, target_by: str = COLOUR,
              segmenter: str = DEFAULT_SEGMENTER) -> TrialRecord:
    """Run one trial of the protocol (module docstring) and return its record.

    `scene` goes to env.reset(scene, seed) unchanged (a name, a YAML path, "random-N" or a SceneSpec); `scene_name`
    labels the record (default str(scene)). `target_by`: how the target is named (``colour``, ``point``, ``mask``:
    pg_learning.evaluation.target_by; point and mask need observations with ``truth_target``); `segmenter`: the
    learned segmenter joining a point's parts (pg_policy.models.click_segmentation.load_segmenter). An Exception of the
    env or the policy ends the trial with termination "error" (the actions before it kept); KeyboardInterrupt and
    other BaseExceptions propagate. An environment whose observations carry no heightmap (test doubles) runs
    without the target memory: counts and limits only.
    """
    t0 = time.perf_counter()
    rec = TrialRecord(scene=scene_name or str(scene), seed=seed)
    primitives = getattr(getattr(env, "geometry", None), "primitives", None)
    target = (None if target_by == COLOUR
              else TrialTarget(target_by, getattr(primitives, "push_length", None), segmenter))
    ep = Episode(limits or Limits(), search_limit=search_limit(target is not None))
    stage = "policy.reset"
    try:
        policy.reset(seed)
        stage = "env.reset"
        obs = observed(ep, env, env.reset(scene, seed), target)
        while not ep.over():
            stage = "policy.act"
            t_act = time.perf_counter()
            decision = policy.act(obs)
            think_s = time.perf_counter() - t_act
            pose = (float(decision.x), float(decision.y), float(decision.z), float(decision.yaw))
            stage = "env.step"
            veto = ep.vet(decision)
            result = refused_step(decision.primitive, veto) if veto is not None else env.step(decision.primitive, *pose)
            ep.record(decision, Outcome(refused=bool(result.refused), target_grasped=bool(result.target_grasped),
                                        message=str(result.message)))
            rec.sim_s += float(result.sim_time)
            rec.actions.append({"index": len(rec.actions), "decision": plain(decision), "outcome": plain(result),
                                "think_s": round(think_s, 4), "note": str(getattr(policy, "last_note", "")),
                                "target": _tracking(getattr(obs, "search", None), target)})
            if not ep.over():  # no observation after the last action: it would not be used
                stage = "env.observe"
                if target is not None:
                    target.acted(decision, result)
                obs = observed(ep, env, env.observe(), target)
    except Exception as exc:  # DESIGN.md section 8: the trial fails with its reason, the run goes on
        mark_error(rec, exc, stage)
        ep.stop(ERROR, f"error at {stage}: {rec.error}")
        log.warning("%s seed %s: trial ended in an error at %s: %s", rec.scene, seed, stage, rec.error)
    rec.completed, rec.termination, rec.message = ep.completed, ep.termination, ep.why
    rec.grasps, rec.target_grasps, rec.failed_grasps = ep.grasps, ep.target_grasps, ep.failed_grasps
    rec.pushes, rec.refused = ep.pushes, ep.refused
    rec.wall_s = time.perf_counter() - t0
    return rec


def refused_step(primitive: str, message: str) -> Any:
    """The StepResult of a decision the episode refused (nothing moved). Imported here: the simulator's modules
    stay out of the processes that only read records (pushgrasp compare, bench on saved cases)."""
    from pg_learning.environment.sim_env import StepResult

    return StepResult(primitive, False, True, False, False, None, message, 0.0)


def observed(ep: Episode, env: EvalEnv, obs: Any, target: TrialTarget | None = None) -> Any:
    """`obs` told to the episode (its target mask, and the simulator's ground truth when `env` has
    `target_outside()`), with the episode's target memory as `search` for the policy; unchanged when it has no
    heightmap. Without `target` the mask is the target colour's; with it, the tracked mask, which the policy gets
    as PolicyObservation.mask."""
    hm = getattr(obs, "heightmap", None)
    if hm is None:
        return obs
    truth = getattr(env, "target_outside", None)
    outside = truth() if callable(truth) else None
    if target is not None:
        mask = target.observe(hm, obs.truth_target)
        return PolicyObservation(hm, obs.target, ep.observe(hm, mask, outside), mask=mask,
                                 unsure=bool(target.view.get("unsure", False)))
    search = ep.observe(hm, target_mask(hm.color, hm.valid, obs.target), outside)
    if is_dataclass(obs) and "search" in {f.name for f in fields(obs)}:
        return replace(obs, search=search)
    return PolicyObservation(hm, obs.target, search)


def _tracking(search: Any, target: TrialTarget | None = None) -> dict[str, Any] | None:
    """The record's view of the target memory an action was decided with: visible, cells, observations hidden in a
    row, last seen (x, y) in `world` m; with a tracked target also its IoU against the ground truth, the ground
    truth's cells, and whether the tracker was unsure and why (TrialTarget.view); None without a memory."""
    if search is None:
        return None
    seen = search.last_seen
    return {"visible": bool(search.visible), "cells": int(search.cells), "hidden_for": int(search.hidden_for),
            "last_seen": None if seen is None else [round(seen.x, 4), round(seen.y, 4)],
            **(target.view if target is not None else {})}


def expand_scenes(items: Sequence[str]) -> list[str]:
    """Scene arguments -> scene names/paths: "packed" and "household" expand to their shipped scenes, "random-N"
    and "dense-N" (generated from the trial seed) stay, anything else must be a shipped scene name or a YAML file.
    Raises SceneError (ValueError) for an unknown one (with close matches) and ValueError for an empty family or
    list."""

    out: list[str] = []
    for item in items:
        if item in FAMILIES:
            names = [n for n in list_scenes() if n.startswith(f"{item}/")]
            if not names:
                raise ValueError(f"scene family {item!r} has no scenes in the scene folders")
            out += names
        elif GENERATED.match(item):
            if int(GENERATED.match(item).group(2)) < 1:  # type: ignore[union-attr]
                raise ValueError(f"{item}: a generated scene needs at least one object")
            out.append(item)
        else:
            find_scene(item)
            out.append(item)
    if not out:
        raise ValueError("no scenes given")
    return out


def jitter_scene(scene: Any, rng: np.random.Generator, xy: float, yaw: float) -> Any:
    """`scene` (a SceneSpec) moved rigidly: rotated by U(-yaw, yaw) rad about its objects' mean (x, y), then shifted
    by U(-xy, xy) m in x and y. Relative object poses are kept; returns the scene unchanged when both are 0."""
    if xy <= 0 and yaw <= 0:
        return scene
    from scipy.spatial.transform import Rotation

    theta = float(rng.uniform(-yaw, yaw)) if yaw > 0 else 0.0
    shift = rng.uniform(-xy, xy, 2) if xy > 0 else np.zeros(2)
    centre = np.mean([o.pose[:2] for o in scene.objects], axis=0)
    rz = Rotation.from_euler("z", theta)
    c, s = math.cos(theta), math.sin(theta)
    objects = []
    for o in scene.objects:
        p = np.asarray(o.pose[:2]) - centre
        x = centre[0] + c * p[0] - s * p[1] + shift[0]
        y = centre[1] + s * p[0] + c * p[1] + shift[1]
        rpy = (rz * Rotation.from_euler("xyz", o.pose[3:])).as_euler("xyz")
        objects.append(replace(o, pose=(float(x), float(y), float(o.pose[2]), *(float(a) for a in rpy))))
    return replace(scene, objects=tuple(objects))


def trial_scene(name: str, seed: int, jitter_xy: float, jitter_yaw: float) -> Any:
    """What env.reset gets for trial `seed` of scene `name`: "random-N" / "dense-N" unchanged, else the loaded and
    jittered SceneSpec (jitter drawn from `seed`)."""

    if GENERATED.match(name):
        return name
    return jitter_scene(load_scene(name), np.random.default_rng(seed), jitter_xy, jitter_yaw)


@dataclass(frozen=True)
class EvalPlan:
    """The trials to run: scenes x trials, seeds seed + i, limits, pose jitter of fixed scenes, the simulation
    mode (pg_sim.world.sim_mode), how trials name the target (`target_by`: colour, point, mask), the colour
    variant (`colours`: pg_sim.world.recolour), the camera (`sensor`: a pg_sim.world.sensor_model profile, checked
    when an environment is made; `calibrate`: calibrated before every trial, pg_learning.environment.sim_calibration),
    the learned segmenter of point targets (`segmenter`: pg_policy.models.click_segmentation.load_segmenter).
    ValueError for an unknown one, or colour targets where colours repeat."""

    scenes: tuple[str, ...]
    trials: int
    seed: int = DEFAULT_SEED
    limits: Limits = field(default_factory=Limits)
    jitter_xy: float = DEFAULT_JITTER_XY
    jitter_yaw: float = DEFAULT_JITTER_YAW
    sim_mode: str = DEFAULT_SIM_MODE
    target_by: str = COLOUR
    colours: str = UNIQUE
    sensor: str = PERFECT
    calibrate: bool = False
    segmenter: str = DEFAULT_SEGMENTER

    def __post_init__(self) -> None:
        check_mode(self.colours)
        check_target_by(self.target_by, self.colours)

    def jobs(self) -> list[tuple[str, int]]:
        """(scene, seed) of every trial, scene-major."""
        if self.trials < 1:
            raise ValueError(f"--trials must be >= 1, got {self.trials}")
        return [(s, self.seed + i) for s in self.scenes for i in range(self.trials)]


def run_plan(make_env: Callable[[], EvalEnv], policy: EvalPolicy, plan: EvalPlan,
             on_trial: Callable[[TrialRecord], None] | None = None) -> list[TrialRecord]:
    """Run every trial of `plan` in order; `on_trial` is called after each trial (run_jobs)."""
    return run_jobs(make_env, policy, plan, plan.jobs(), on_trial)


def run_jobs(make_env: Callable[[], EvalEnv], policy: EvalPolicy, plan: EvalPlan, jobs: Sequence[tuple[str, int]],
             on_trial: Callable[[TrialRecord], None] | None = None) -> list[TrialRecord]:
    """Run the trials `jobs` ((scene, seed) pairs of `plan`) in order, in this process; `on_trial` is called after
    each trial.

    Each trial gets a fresh environment from `make_env()` (closed afterwards when it has close()): PyBullet's
    contact solver keeps state between calls, so a world that ran other trials before would not reproduce a trial
    exactly. With a fresh world per trial, a trial's record depends only on (policy, scene, seed, limits, jitter).
    """
    out = []
    for name, seed in jobs:
        out.append(run_fresh(make_env, policy, name, seed, plan))
        if on_trial is not None:
            on_trial(out[-1])
    return out


def run_fresh(make_env: Callable[[], EvalEnv], policy: EvalPolicy, name: str, seed: int,
              plan: EvalPlan) -> TrialRecord:
    """One trial of `plan` (scene `name`, `seed`) in a fresh environment from `make_env()`. An Exception while
    building the scene or the environment ends the trial as an error too (see run_trial)."""
    t0 = time.perf_counter()
    stage = "scene"
    try:
        scene = trial_scene(name, seed, plan.jitter_xy, plan.jitter_yaw)
        stage = "env.make"
        env = make_env()
    except Exception as exc:
        rec = mark_error(TrialRecord(scene=name, seed=seed), exc, stage)
        log.warning("%s seed %s: trial ended in an error at %s: %s", name, seed, stage, rec.error)
        rec.wall_s = time.perf_counter() - t0
        return rec
    try:
        return run_trial(env, policy, scene, seed, plan.limits, scene_name=name, target_by=plan.target_by,
                         segmenter=plan.segmenter)
    finally:
        close = getattr(env, "close", None)
        if close is not None:
            try:
                close()
            except Exception as exc:  # the trial's record stands; a simulator that fails to close is only logged
                log.warning("%s seed %s: closing the environment failed: %r", name, seed, exc)
