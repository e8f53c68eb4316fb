"""The grasp-a-target loop of the policy node, ROS-free (DESIGN.md sections 5 and 8).

heightmap -> target mask -> policy decision -> execute the primitive -> wait for a fresh heightmap -> check, until
the target is held, `max_failed_grasps` grasps failed, `max_actions` actions were taken, or the call's time budget
is spent (or MAX_FAILED_PRIMITIVES primitives in a row were refused or aborted). The same stopping rules as
pg_policy.evaluation.trials.run_trial; the difference is where observations and outcomes come from:
a HeightmapSource (the /pg/heightmap topic in the node) and a PrimitiveExecutor (the /pg/execute_primitive
service), so sim and real robot run the same loop.

Which object a grasp lifted is not known to a real robot: the target counts as grasped when the gripper holds
something (fingers not closed) and the target has left the next heightmap (fewer than TARGET_GONE_FRACTION of its
cells before the grasp remain, or fewer than MIN_VISIBLE_CELLS).

Times: `stamp` values are ROS time in seconds (sim time under /use_sim_time); every wait is bounded in wall-clock
seconds, so a dead simulator (frozen clock) cannot hang a call.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, Protocol

import numpy as np

from pg_core.heightmap import Heightmap
from pg_core.palette import normalize_name
from pg_core.target_mask import MIN_VISIBLE_CELLS, hsv_window, target_mask
from pg_policy.decision.decision import Decision
from pg_policy.target_loop.limits import DEFAULT_MAX_ACTIONS, DEFAULT_MAX_FAILED_GRASPS

TARGET_GONE_FRACTION = 0.2
MAX_FAILED_PRIMITIVES = 3  # refused/aborted primitives in a row that end a call (a deterministic policy repeats)
DEFAULT_TIMEOUT_S = 600.0


class LoopError(RuntimeError):
    """A call that cannot start or go on: unknown colour, target not visible, no heightmap, ... (message says)."""


class NoHeightmap(LoopError, TimeoutError):
    """No heightmap newer than the requested stamp arrived within the wait."""


@dataclass(frozen=True)
class StampedHeightmap:
    heightmap: Heightmap
    stamp: float  # ROS time (s) of the source point cloud


@dataclass(frozen=True)
class Execution:
    """Outcome of one primitive. success: it ran to its end; grasped: grasp only, fingers not closed after the lift;
    arm: the arm that moved; duration: ROS seconds; end_stamp: ROS time when it finished."""

    success: bool
    grasped: bool
    arm: str
    message: str
    duration: float
    end_stamp: float


class HeightmapSource(Protocol):
    def wait_after(self, stamp: float, timeout_s: float) -> StampedHeightmap:
        """The latest heightmap stamped strictly after `stamp`; raises NoHeightmap after timeout_s wall seconds."""
        ...


class PrimitiveExecutor(Protocol):
    def execute(self, decision: Decision, timeout_s: float) -> Execution:
        """Run the decision's primitive; raises LoopError when the executor cannot be reached at all."""
        ...


@dataclass(frozen=True)
class LoopLimits:
    max_actions: int = DEFAULT_MAX_ACTIONS
    max_failed_grasps: int = DEFAULT_MAX_FAILED_GRASPS
    timeout_s: float = DEFAULT_TIMEOUT_S  # wall seconds for the whole call

    def __post_init__(self) -> None:
        if self.max_actions < 1 or self.max_failed_grasps < 1 or not self.timeout_s > 0:
            raise ValueError(f"limits must be positive, got {self}")


@dataclass
class ActionRecord:
    """One decision and, when executed, its outcome (the content of a pg_msgs/Decision)."""

    episode: int
    index: int
    target: str
    policy: str
    decision: Decision
    heightmap_stamp: float
    decided_stamp: float
    target_pixels: int
    grasp_threshold: float = math.nan
    execution: Execution | None = None
    target_grasped: bool = False


@dataclass
class LoopResult:
    success: bool
    grasps: int = 0
    pushes: int = 0
    duration: float = 0.0  # ROS seconds
    wall_time: float = 0.0
    message: str = ""
    actions: list[ActionRecord] = field(default_factory=list)
    failed_grasps: int = 0
    refused: int = 0  # primitives the controller refused or aborted


def check_target(name: str) -> str:
    """Normalised palette colour name; LoopError listing the known colours for an unknown one."""
    try:
        hsv_window(name or "green")
    except ValueError as exc:
        raise LoopError(str(exc)) from None
    return normalize_name(name or "green")


def mask_of(hm: Heightmap, target: str) -> np.ndarray:
    return target_mask(hm.color, hm.valid, target)


@dataclass
class PolicyObservation:
    """What pg_policy.policies.registry act on: the heightmap and the target's colour name."""

    heightmap: Heightmap
    target: str


class TargetLoop:
    """Runs grasp-target calls with one policy. Not re-entrant: the caller refuses concurrent calls.

    clock: ROS time now (s). on_decision: called with each record and its heightmap right after deciding, before
    anything runs (the node draws it); on_action: called with each record once its outcome is known (the node
    publishes it).
    heightmap_timeout_s: wall seconds to wait for a fresh heightmap before giving up with NoHeightmap.
    """

    def __init__(self, policy: Any, source: HeightmapSource, executor: PrimitiveExecutor, clock: Callable[[], float],
                 policy_name: str = "", heightmap_timeout_s: float = 5.0,
                 on_action: Callable[[ActionRecord], None] | None = None,
                 on_decision: Callable[[ActionRecord, StampedHeightmap], None] | None = None) -> None:
        self.policy = policy
        self.source = source
        self.executor = executor
        self.clock = clock
        self.policy_name = policy_name or getattr(policy, "name", "policy")
        self.heightmap_timeout_s = heightmap_timeout_s
        self.on_action = on_action
        self.on_decision = on_decision
        self.episode = 0
        self.last_q: dict[str, np.ndarray] = {}
        self._after: StampedHeightmap | None = None

    @property
    def threshold(self) -> float:
        return float(getattr(self.policy, "threshold", math.nan))

    def decide(self, target: str, shm: StampedHeightmap, index: int = 0, episode: int = 0) -> ActionRecord:
        """One decision on a heightmap; LoopError when the target is not visible there."""
        mask = mask_of(shm.heightmap, target)
        pixels = int(mask.sum())
        if pixels < MIN_VISIBLE_CELLS:
            raise LoopError(f"target '{target}' not visible: {pixels} matching heightmap cells "
                            f"(at least {MIN_VISIBLE_CELLS} needed)")
        decision = self.policy.act(PolicyObservation(shm.heightmap, target))
        self.last_q = self.policy.q_maps()
        rec = ActionRecord(episode, index, target, self.policy_name, decision, shm.stamp, self.clock(), pixels,
                           self.threshold)
        if self.on_decision:
            self.on_decision(rec, shm)
        return rec

    def infer(self, target: str) -> ActionRecord:
        """The decision on the first heightmap newer than now (nothing executed)."""
        target = check_target(target)
        self.policy.reset(0)
        return self.decide(target, self.source.wait_after(self.clock(), self.heightmap_timeout_s))

    def run(self, target: str, limits: LoopLimits | None = None,
            cancelled: Callable[[], bool] | None = None) -> LoopResult:
        """One call: raises LoopError before anything moves (unknown colour, no heightmap, target not visible);
        later problems end the call with success False and the reason in the result's message. `cancelled` is
        asked between actions (a running primitive always finishes); True ends the call with message "cancelled"."""
        limits = limits or LoopLimits()
        target = check_target(target)
        t0, wall0 = self.clock(), time.monotonic()
        shm = self.source.wait_after(t0, self.heightmap_timeout_s)
        self.episode += 1
        self.policy.reset(self.episode)
        res = LoopResult(success=False)
        rec = self.decide(target, shm, 0, self.episode)
        try:
            while True:
                done = self._step(rec, res, limits, wall0)
                res.message = done or res.message
                if done:
                    break
                if res.failed_grasps >= limits.max_failed_grasps:
                    res.message = f"gave up after {res.failed_grasps} failed grasps"
                    break
                if len(res.actions) >= limits.max_actions:
                    res.message = f"action budget of {limits.max_actions} spent"
                    break
                if time.monotonic() - wall0 > limits.timeout_s:
                    res.message = f"time budget of {limits.timeout_s:.0f} s spent"
                    break
                if cancelled is not None and cancelled():
                    res.message = "cancelled"
                    break
                rec = self.decide(target, self._fresh(rec), len(res.actions), self.episode)
        except LoopError as exc:
            res.message = f"stopped after {len(res.actions)} actions: {exc}"
        res.duration, res.wall_time = self.clock() - t0, time.monotonic() - wall0
        return res

    def _fresh(self, rec: ActionRecord) -> StampedHeightmap:
        """The first heightmap taken after the record's action ended (fetched once per action)."""
        end = rec.execution.end_stamp if rec.execution else rec.decided_stamp
        if self._after is None or self._after.stamp <= end:
            self._after = self.source.wait_after(end, self.heightmap_timeout_s)
        return self._after

    def _step(self, rec: ActionRecord, res: LoopResult, limits: LoopLimits, wall0: float) -> str:
        """Execute one decision and record its outcome; returns a non-empty message when the call is over."""
        budget = max(limits.timeout_s - (time.monotonic() - wall0), 1.0)
        ex = self.executor.execute(rec.decision, budget)
        rec.execution = ex
        res.actions.append(rec)
        done = ""
        if not ex.success:
            res.refused += 1
            streak = 0
            for r in reversed(res.actions):
                if r.execution is None or r.execution.success:
                    break
                streak += 1
            if streak >= MAX_FAILED_PRIMITIVES:
                done = f"{streak} primitives in a row failed, last: {ex.message}"
        elif rec.decision.primitive == "push":
            res.pushes += 1
        else:
            res.grasps += 1
            if ex.grasped:
                after = mask_of(self._fresh(rec).heightmap, rec.target).sum()
                rec.target_grasped = after < max(MIN_VISIBLE_CELLS, TARGET_GONE_FRACTION * rec.target_pixels)
            if rec.target_grasped:
                res.success, done = True, f"target '{rec.target}' grasped"
            else:
                res.failed_grasps += 1
        if self.on_action:
            self.on_action(rec)
        return done
