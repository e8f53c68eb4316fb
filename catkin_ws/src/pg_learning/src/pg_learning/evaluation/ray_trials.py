"""Trials on Ray actors: `pushgrasp eval --workers N` (a local Ray of N CPUs) and `--ray-address auto|HOST:PORT`
(a cluster; docs/CLUSTER.md).

Each actor holds one policy, made once by ``init(*initargs)``, and runs one trial at a time,
``trial_fn(index, name, seed, plan) -> (index, TrialRecord)``, every trial in a fresh PyBullet DIRECT client; the
driver keeps every actor busy and hands out trials in job order. Records do not depend on which actor ran them (each
trial is seeded and starts from a fresh simulator), so the results equal the serial run's trial by trial.

Failures (an Exception inside a trial is already a record, pg_learning.evaluation.runner):
  - a job that raises outside the trial (e.g. its record cannot be sent back): an error record, stage "worker";
  - an actor that dies while running a trial (killed, out of memory, a crash in native code, its node lost): a
    replacement starts in the background while the other actors go on, and the trial runs once more (first in
    line); dying a second time records it as an error (stage "worker", WORKER_DIED and Ray's reason);
  - an actor whose `init` raises: the workers cannot start; every unfinished trial is recorded as an error with
    that reason (the run ends with what it has instead of looping);
  - no actor starting within `start_timeout_s` (the cluster has no free CPU): that actor is given up; with no
    actor at the start, TimeoutError; with none left later, WorkersLost (a ConnectionError; the finished trials
    were already handed to `on_trial`), so the run goes on with fewer actors as long as one is alive.
Every wait is bounded (``ray.wait`` polls every `poll_s` s, so Ctrl-C is seen at once); KeyboardInterrupt
propagates, and leaving the Ray session stops the actors.
"""

from __future__ import annotations

import os
import time
from collections import deque
from collections.abc import Callable, Sequence
from typing import Any

from pg_learning.cluster.ray_session import RayInfo, ray_session
from pg_learning.evaluation.errors import describe, mark_error
from pg_policy.target_loop.records import TrialRecord

WORKER_DIED = "process died"
RETRIES = 1  # runs of a trial after the one whose actor died
START_TIMEOUT_S = 180.0  # an actor imports torch and pybullet and loads the policy first
POLL_S = 1.0


class TrialWorker:
    """The body of one Ray actor (wrapped with ray.remote by run_on_ray): a policy made by `init`, trials by
    `trial_fn`."""

    def __init__(self, init: Callable[..., None], initargs: tuple, trial_fn: Callable[..., tuple[int, Any]]) -> None:
        init(*initargs)
        self.trial_fn = trial_fn

    def ready(self) -> int:
        """The actor's process id, once `init` has run."""
        return os.getpid()

    def run(self, index: int, name: str, seed: int, plan: Any) -> tuple[int, Any]:
        return self.trial_fn(index, name, seed, plan)


class _Run:
    """One evaluation on Ray: jobs, records by index, the actors and the trials they run."""

    def __init__(self, ray: Any, jobs: Sequence[tuple[str, int]], plan: Any, actor_cls: Any, actor_args: tuple,
                 on_trial: Callable[[TrialRecord], None] | None, start_timeout_s: float) -> None:
        self.ray, self.jobs, self.plan, self.actor_cls, self.actor_args = ray, jobs, plan, actor_cls, actor_args
        self.on_trial, self.start_timeout_s = on_trial, start_timeout_s
        self.results: list[TrialRecord | None] = [None] * len(jobs)
        self.deaths = [0] * len(jobs)
        self.inflight: dict[Any, tuple[int, Any]] = {}  # ObjectRef -> (job index, actor)

    def start(self, n: int) -> list[Any]:
        """Up to `n` actors that finished `init` within start_timeout_s (the others are killed). Raises
        _CannotStart when an actor's init raised."""
        ray = self.ray
        actors = [self.actor_cls.remote(*self.actor_args) for _ in range(n)]
        refs = {a.ready.remote(): a for a in actors}
        ready, late = ray.wait(list(refs), num_returns=len(refs), timeout=self.start_timeout_s)
        started = []
        for ref in ready:
            try:
                ray.get(ref, timeout=self.start_timeout_s)
                started.append(refs[ref])
            except ray.exceptions.RayActorError as exc:  # init raised, or the process died while starting
                for a in actors:
                    ray.kill(a)
                raise _CannotStart(f"{WORKER_DIED} before starting its trial: {describe(_cause(exc))}") from exc
        for ref in late:
            ray.kill(refs[ref])
        return started

    def done(self, i: int, rec: TrialRecord) -> None:
        self.results[i] = rec
        if self.on_trial is not None:
            self.on_trial(rec)

    def failed(self, i: int, exc: BaseException | None, text: str | None = None) -> TrialRecord:
        """The error record of job `i` (stage "worker"; no actions: they were lost with the actor)."""
        name, seed = self.jobs[i]
        return mark_error(TrialRecord(scene=name, seed=seed), exc, "worker", text)

    def submit(self, actor: Any, i: int) -> None:
        name, seed = self.jobs[i]
        self.inflight[actor.run.remote(i, name, seed, self.plan)] = (i, actor)

    def collect(self, ref: Any) -> tuple[int, Any, bool]:
        """(job index, actor, whether the actor died) of a finished job; records the job unless it is to be
        retried."""
        ray = self.ray
        i, actor = self.inflight.pop(ref)
        try:
            self.done(i, ray.get(ref, timeout=self.start_timeout_s)[1])
            return i, actor, False
        except ray.exceptions.RayActorError as exc:
            self.deaths[i] += 1
            if self.deaths[i] > RETRIES:
                self.done(i, self.failed(i, None, f"{WORKER_DIED} running this trial ({self.deaths[i]} times): "
                                                  f"{describe(_cause(exc))}"))
            return i, actor, True
        except ray.exceptions.RayTaskError as exc:  # the job raised outside the trial
            self.done(i, self.failed(i, _cause(exc)))
            return i, actor, False


class WorkersLost(ConnectionError):
    """Every actor died and none could be replaced (e.g. the cluster's nodes were lost)."""


class _CannotStart(RuntimeError):
    """An actor's init raised: no worker can run trials."""


def _cause(exc: BaseException) -> BaseException:
    """The user's exception inside a Ray error when Ray kept it, else the Ray error."""
    return getattr(exc, "cause", None) or exc


def run_on_ray(jobs: Sequence[tuple[str, int]], plan: Any, workers: int, trial_fn: Callable[..., Any],
               init: Callable[..., None], initargs: tuple = (), on_trial: Callable[[TrialRecord], None] | None = None,
               address: str | None = None, start_timeout_s: float = START_TIMEOUT_S,
               on_start: Callable[[RayInfo, int], None] | None = None) -> list[TrialRecord]:
    """Records of `jobs` ((scene, seed) pairs of `plan`) in job order, run by Ray actors (module docstring):
    `workers` actors on a local Ray of `workers` CPUs, or on the cluster at `address` (`workers` 0 = one per CPU of
    the cluster). `on_trial(record)` is called in the driver as each trial finishes; `on_start(info, actors)` once
    the actors are up. `trial_fn` and `init` must be importable by the workers (module functions)."""
    if not jobs:
        return []
    with ray_session(max(1, workers), address) as info:
        import ray

        n = workers if workers > 0 else max(1, info.cpus)
        actor_cls = ray.remote(num_cpus=1, max_restarts=0, max_task_retries=0)(TrialWorker)
        run = _Run(ray, jobs, plan, actor_cls, (init, initargs, trial_fn), on_trial, start_timeout_s)
        queue = deque(range(len(jobs)))
        try:
            actors = run.start(min(n, len(jobs)))
        except _CannotStart as exc:
            for i in queue:
                run.done(i, run.failed(i, None, str(exc)))
            return [r for r in run.results if r is not None]
        if not actors:
            raise TimeoutError(f"no Ray worker started within {start_timeout_s:.0f} s on {info.address} "
                               f"({info.cpus} CPUs in the cluster, all busy?)")
        if on_start is not None:
            on_start(info, len(actors))
        idle = list(actors)
        starting: dict[Any, tuple[Any, float]] = {}  # ready() ref of a replacement -> (actor, start time)
        while queue or run.inflight:
            while idle and queue:
                run.submit(idle.pop(), queue.popleft())
            if queue and not run.inflight and not starting:
                left = sum(r is None for r in run.results)
                raise WorkersLost(f"every Ray worker died or could not be replaced; {left} trials did not run: "
                                  "the finished ones are kept, run the same command again to resume")
            ready, _ = ray.wait([*run.inflight, *starting], num_returns=1, timeout=POLL_S)
            for ref in ready:
                if ref in starting:
                    actor, _ = starting.pop(ref)
                    try:
                        ray.get(ref, timeout=start_timeout_s)
                        idle.append(actor)
                    except ray.exceptions.RayActorError as exc:
                        print(f"[eval] a replacement Ray worker could not start: {describe(_cause(exc))}")
                    continue
                i, actor, died = run.collect(ref)
                if not died:
                    idle.append(actor)
                    continue
                if run.results[i] is None:
                    queue.appendleft(i)  # its second run goes first
                replacement = actor_cls.remote(init, initargs, trial_fn)  # started in the background
                starting[replacement.ready.remote()] = (replacement, time.monotonic())
            for ref, (actor, t0) in list(starting.items()):
                if time.monotonic() - t0 > start_timeout_s:  # e.g. the cluster lost the node's CPUs
                    print(f"[eval] a replacement Ray worker did not start within {start_timeout_s:.0f} s")
                    ray.kill(actor)
                    del starting[ref]
        return [r for r in run.results if r is not None]
