"""The grasp-a-target loop of the policy node, ROS-free (DESIGN.md sections 5 and 8).

heightmap -> target mask -> target memory -> policy decision -> execute the primitive -> wait for a fresh heightmap
-> check, under the one episode protocol (pg_policy.target_loop.episode, shared with the evaluation and training):
until the target is held, it has left the workspace ("target lost: <why>"), the search for a hidden target has
found nothing ("target not found: <why>", pg_policy.perception.target_memory), `max_failed_grasps` grasps failed,
`max_actions` actions were taken, MAX_FAILED_PRIMITIVES primitives in a row were refused or aborted, the call's time
budget is spent, the call is cancelled, or the scene was replaced under the call (RESET_MESSAGE: the scene token
`scene_epoch` changed, e.g. the simulator's reset count). What differs from the evaluation is where observations
and outcomes come from: a HeightmapSource (the /pg/heightmap topic in the node) and a PrimitiveExecutor (the
/pg/execute_primitive service), so sim and real robot run the same loop.

Targets: a colour name (str) or a pg_policy.target_loop.target_spec spec (ColourTarget, PointTarget, MaskTarget).
A colour goes the colour path (the mask of every heightmap is the palette colour's cells, the policy finds the
target by its name). A point or a mask gets a TargetFollower per call: its mask of each heightmap goes to the
episode and to the policy (`PolicyObservation.mask`); a track in doubt is said in the record's note ("target track
unsure: <why>"), and a call that ends with a grasp made in doubt says so in its message ("...; the track was in
doubt at that grasp (<why>): the object held may be another one"): a real robot cannot tell which object it lifted.
A point or mask the first heightmap refuses (off the grid, bare table, covering no object) raises TargetRefused,
before anything moves, its message naming the spec's field.

A target not visible on the first heightmap of a call is refused before anything moves (LoopError). Once the call
has acted, a hidden target is searched for where it was last seen (pg_policy.perception.target_memory; the policy
gets the memory as `obs.search`), and a push that changed nothing is never repeated at the same place and rotation
(the episode refuses it: a refused action).

Which object a grasp lifted is not known to a real robot: the target counts as grasped when the gripper holds
something (fingers not closed) and the target has left the next heightmap (fewer than TARGET_GONE_FRACTION of its
cells before the grasp remain, or fewer than MIN_VISIBLE_CELLS).

Times: `stamp` values are ROS time in seconds (sim time under /use_sim_time); every wait and the call's time budget
are wall-clock seconds, so a dead simulator (frozen clock) cannot hang a call and a budget means the same however
fast the simulation runs. The budget is checked between actions: the action under way always finishes (its
primitive is given what is left of the budget, at least 1 s).

Threads: every policy computation (reset, act, q_maps) of a TargetLoop runs on its one worker thread
(pg_policy.target_loop.worker.PinnedThread) whichever thread calls run/infer/decide, so that the nets' buffers
live in one malloc arena (see that module); after each run and infer the free heap goes back to the system
(pg_core.heap_trim), so the node's RSS does not stay at the largest peak a call reached.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from typing import Any

import numpy as np

from pg_core.heap_trim import release_free_memory
from pg_core.target_mask import MIN_VISIBLE_CELLS
from pg_policy.models.click_segmentation import DEFAULT_SEGMENTER, load_segmenter
from pg_policy.perception.target_memory import search_limit
from pg_policy.target_loop.episode import (
    CANCELLED,
    COMPLETED,
    ERROR,
    SCENE_RESET,
    TIME_BUDGET,
    Episode,
    Limits,
    Outcome,
)
from pg_policy.target_loop.loop_limits import LoopLimits
from pg_policy.target_loop.loop_types import (
    ActionRecord,
    Execution,
    HeightmapSource,
    LoopError,
    LoopResult,
    PolicyObservation,
    PrimitiveExecutor,
    SceneReset,
    StampedHeightmap,
    TargetRefused,
    as_spec,
    mask_of,
    target_label,
)
from pg_policy.target_loop.target_spec import ColourTarget, TargetFollower, TargetSpec
from pg_policy.target_loop.worker import PinnedThread

TARGET_GONE_FRACTION = 0.2
MAX_FAILED_PRIMITIVES = 3  # refused/aborted primitives in a row that end a call (a deterministic policy repeats)
RESET_MESSAGE = "the scene was reset during the call"


class TargetLoop:
    """Runs grasp-target calls with one policy. Not re-entrant: the caller refuses concurrent calls.

    clock: ROS time now (s). on_decision: called with each record and its heightmap right after deciding, before
    anything runs (the node draws it); on_action: called with each record once its outcome is known (the node
    publishes it).
    heightmap_timeout_s: wall seconds to wait for a fresh heightmap before giving up with NoHeightmap.
    scene_epoch: a token of the scene in front of the robot, None while unknown (the node: the simulator's latched
    reset count; a real cell has none and never changes it). A change before the call's first primitive makes it
    decide anew on a fresh heightmap (the count may arrive after a call that follows a reset has started); once an
    action has run, a call ends with RESET_MESSAGE when the token differs
    from the one it started with (or, started unknown, from the first one it saw): checked before every primitive
    and around every heightmap it waits for, i.e. between primitives.
    segmenter: the learned segmenter that joins a point target's parts in its first view
    (pg_policy.models.click_segmentation.load_segmenter: "none", the default, "shipped" or a model file;
    FileNotFoundError for a file that is not there).
    Callbacks (on_decision, on_action, the `cancelled` of run) are called on the worker thread.
    """

    def __init__(self, policy: Any, source: HeightmapSource, executor: PrimitiveExecutor, clock: Callable[[], float],
                 policy_name: str = "", heightmap_timeout_s: float = 5.0,
                 on_action: Callable[[ActionRecord], None] | None = None,
                 on_decision: Callable[[ActionRecord, StampedHeightmap], None] | None = None,
                 scene_epoch: Callable[[], object] | None = None, segmenter: str = DEFAULT_SEGMENTER) -> None:
        self.policy = policy
        self.segmenter = segmenter  # joins a point target's parts (pg_policy.models.click_segmentation)
        load_segmenter(segmenter)  # a missing model file is refused at construction
        self.source = source
        self.executor = executor
        self.clock = clock
        self.policy_name = policy_name or getattr(policy, "name", "policy")
        self.heightmap_timeout_s = heightmap_timeout_s
        self.on_action = on_action
        self.on_decision = on_decision
        self.episode = 0
        self.last_q: dict[str, np.ndarray] = {}
        self.scene_epoch = scene_epoch or (lambda: None)
        self.worker = PinnedThread()
        self._after: StampedHeightmap | None = None  # per call: the heightmap after the last action
        self._follower: TargetFollower | None = None  # per call: point / mask targets (None: colour)
        self._seen: tuple[StampedHeightmap, np.ndarray] | None = None  # per call: the follower's latest mask
        self._epoch: object = None  # per call: the scene token the call belongs to

    @property
    def threshold(self) -> float:
        return float(getattr(self.policy, "threshold", math.nan))

    def decide(self, target: str | TargetSpec, shm: StampedHeightmap, index: int = 0,
               episode: int = 0) -> ActionRecord:
        """One decision on a heightmap with no target memory; LoopError when the target is not visible there
        (TargetRefused for a point or mask it refuses)."""
        return self.worker.call(self._decide_on, as_spec(target), shm, index, episode)

    def _decide_on(self, spec: TargetSpec, shm: StampedHeightmap, index: int, episode: int) -> ActionRecord:
        self._start_target(spec)
        rec = self._decide(target_label(spec), shm, index, episode)
        assert rec is not None  # without an episode a decision is always taken (or LoopError raised)
        return rec

    def _start_target(self, spec: TargetSpec) -> None:
        """Per call: a fresh TargetFollower for a point or mask target (colour: none, the colour path)."""
        push_length = getattr(getattr(self.policy, "prims", None), "push_length", None)
        self._follower = (None if isinstance(spec, ColourTarget)
                          else TargetFollower(spec, push_length, self.segmenter))
        self._seen = None

    def _target_mask(self, target: str, shm: StampedHeightmap) -> np.ndarray:
        """(H, W) bool target mask of `shm`: the colour's cells, or the follower's mask (asked once per heightmap:
        the grasp check and the next decision share the heightmap after an action)."""
        if self._follower is None:
            return mask_of(shm.heightmap, target)
        if self._seen is not None and self._seen[0] is shm:
            return self._seen[1]
        first = self._follower.track is None
        try:
            mask = np.asarray(self._follower.mask(shm.heightmap), dtype=bool)
        except ValueError as exc:
            if not first:
                raise
            raise TargetRefused(str(exc)) from None
        self._seen = (shm, mask)
        return mask

    def _decide(self, target: str, shm: StampedHeightmap, index: int = 0, episode: int = 0,
                ep: Episode | None = None) -> ActionRecord | None:
        """The decision on `shm`. Without an episode (or before its first action) LoopError when the target is not
        visible; within one, the heightmap goes to the episode's target memory first, and None means the episode
        ended on it (the target left the workspace). `target`: the colour name, or the label of a followed point
        or mask target (self._follower)."""
        mask = self._target_mask(target, shm)
        pixels = int(mask.sum())
        if (ep is None or ep.actions == 0) and pixels < MIN_VISIBLE_CELLS:
            raise LoopError(f"target '{target}' not visible: {pixels} matching heightmap cells "
                            f"(at least {MIN_VISIBLE_CELLS} needed)")
        search = None
        if ep is not None:
            search = ep.observe(shm.heightmap, mask)
            if ep.over():
                return None
        follower = self._follower
        obs = PolicyObservation(shm.heightmap, target, search, mask if follower is not None else None,
                                unsure=follower is not None and follower.unsure)
        decision = self.policy.act(obs)
        self.last_q = self.policy.q_maps()
        note = str(getattr(self.policy, "last_note", ""))
        doubt = follower.why if follower is not None and follower.unsure else ""
        if doubt:
            note = "; ".join(n for n in (f"target track unsure: {doubt}", note) if n)
        rec = ActionRecord(episode, index, target, self.policy_name, decision, shm.stamp, self.clock(), pixels,
                           self.threshold, note=note, target_mask=mask if follower is not None else None,
                           track_doubt=doubt)
        if self.on_decision:
            self.on_decision(rec, shm)
        return rec

    def infer(self, target: str | TargetSpec) -> ActionRecord:
        """The decision on the first heightmap newer than now (nothing executed)."""
        spec = as_spec(target)
        return self.infer_on(spec, self.source.wait_after(self.clock(), self.heightmap_timeout_s))

    def infer_on(self, target: str | TargetSpec, shm: StampedHeightmap) -> ActionRecord:
        """The decision on `shm` with no memory of earlier decisions (policy reset; nothing executed)."""
        try:
            return self.worker.call(self._infer_on, as_spec(target), shm)
        finally:
            release_free_memory()

    def _infer_on(self, spec: TargetSpec, shm: StampedHeightmap) -> ActionRecord:
        self.policy.reset(0)
        return self._decide_on(spec, shm, 0, 0)

    def run(self, target: str | TargetSpec, limits: LoopLimits | None = None,
            cancelled: Callable[[], bool] | None = None) -> LoopResult:
        """One call: raises LoopError before anything moves (unknown colour, no heightmap, target not visible,
        TargetRefused for a point or mask the first heightmap refuses);
        later problems end the call with success False and the reason in the result's message (and `termination`,
        pg_policy.target_loop.episode). `cancelled` is asked between actions (a running primitive always finishes);
        True ends the call with message "cancelled". A scene reset (see the class) ends it with RESET_MESSAGE; a
        target that left the workspace with "target lost: <why>"."""
        try:
            return self.worker.call(self._run, as_spec(target), limits or LoopLimits(), cancelled)
        finally:
            release_free_memory()

    def _episode(self, target: str, limits: LoopLimits) -> Episode:
        return Episode(Limits(limits.max_actions, limits.max_failed_grasps), target=target,
                       max_refused_in_row=MAX_FAILED_PRIMITIVES,
                       search_limit=search_limit(self._follower is not None))

    def _run(self, spec: TargetSpec, limits: LoopLimits, cancelled: Callable[[], bool] | None) -> LoopResult:
        target = target_label(spec)
        self._start_target(spec)
        self._after, self._epoch = None, self.scene_epoch()
        t0, wall0 = self.clock(), time.monotonic()
        shm = self.source.wait_after(t0, self.heightmap_timeout_s)
        self.episode += 1
        self.policy.reset(self.episode)
        ep = self._episode(target, limits)
        res = LoopResult(success=False)
        rec = self._decide(target, shm, 0, self.episode, ep)
        try:
            while rec is not None:
                try:
                    self._check_scene()
                except SceneReset:
                    if res.actions:
                        raise
                    # nothing moved yet: the reset came before the first primitive (its count may arrive after the
                    # call started), so the call decides anew on the scene now in front of the robot
                    self._epoch = self.scene_epoch()
                    self.policy.reset(self.episode)
                    self._start_target(spec)
                    ep = self._episode(target, limits)
                    rec = self._decide(target, self.source.wait_after(self.clock(), self.heightmap_timeout_s), 0,
                                       self.episode, ep)
                    continue
                self._step(rec, res, ep, limits, wall0)
                if ep.over():
                    break
                if time.monotonic() - wall0 > limits.timeout_s:
                    ep.stop(TIME_BUDGET, f"time budget of {limits.timeout_s:g} s spent")
                    break
                if cancelled is not None and cancelled():
                    ep.stop(CANCELLED, "cancelled")
                    break
                rec = self._decide(target, self._fresh(rec), len(res.actions), self.episode, ep)
        except SceneReset:
            ep.stop(SCENE_RESET, f"{RESET_MESSAGE}: stopped after {len(res.actions)} actions")
        except LoopError as exc:
            ep.stop(ERROR, f"stopped after {len(res.actions)} actions: {exc}")
        ep.over()
        res.success, res.message, res.termination = ep.termination == COMPLETED, ep.why, ep.termination
        if res.success and res.actions and res.actions[-1].track_doubt:
            res.message += (f"; the track was in doubt at that grasp ({res.actions[-1].track_doubt}): "
                            "the object held may be another one")
        res.grasps, res.pushes, res.failed_grasps, res.refused = ep.grasps, ep.pushes, ep.failed_grasps, ep.refused
        res.duration, res.wall_time = self.clock() - t0, time.monotonic() - wall0
        return res

    def _check_scene(self) -> None:
        """SceneReset when the scene token differs from the call's (adopting the first known one)."""
        now = self.scene_epoch()
        if self._epoch is None:
            self._epoch = now
        elif now is not None and now != self._epoch:
            raise SceneReset(RESET_MESSAGE)

    def _fresh(self, rec: ActionRecord) -> StampedHeightmap:
        """The first heightmap taken after the record's action ended (fetched once per action); SceneReset when the
        scene was replaced before or while waiting for it."""
        end = rec.execution.end_stamp if rec.execution else rec.decided_stamp
        self._check_scene()
        if self._after is None or self._after.stamp <= end:
            self._after = self.source.wait_after(end, self.heightmap_timeout_s)
            self._check_scene()
        return self._after

    def _step(self, rec: ActionRecord, res: LoopResult, ep: Episode, limits: LoopLimits, wall0: float) -> None:
        """Execute one decision (unless the episode refuses it: a futile push repeated) and count its outcome in
        `ep`. The record reaches on_action also when checking its outcome raised (no heightmap, scene reset)."""
        veto = ep.vet(rec.decision)
        if veto is not None:
            ex = Execution(False, False, "", veto, 0.0, self.clock())
        else:
            ex = self.executor.execute(rec.decision, max(limits.timeout_s - (time.monotonic() - wall0), 1.0))
        rec.execution = ex
        res.actions.append(rec)
        if self._follower is not None:  # where an executed push carried the target: the next mask looks there
            d = rec.decision
            self._follower.acted(d.primitive, d.x, d.y, d.yaw, ex.success)
        try:
            if ex.success and rec.decision.primitive == "grasp" and ex.grasped:
                after = self._target_mask(rec.target, self._fresh(rec)).sum()
                rec.target_grasped = bool(after < max(MIN_VISIBLE_CELLS, TARGET_GONE_FRACTION * rec.target_pixels))
        finally:
            ep.record(rec.decision, Outcome(refused=not ex.success, target_grasped=rec.target_grasped,
                                            message=ex.message))
            if self.on_action:
                self.on_action(rec)
