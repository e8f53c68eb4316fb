"""Trials in a pool of worker processes that survives its workers (`pushgrasp eval --workers N`).

Each trial is a job ``trial_fn(index, name, seed, plan) -> (index, TrialRecord)`` run by a worker that
``init(*initargs)`` prepared. An Exception inside a trial is already a record (pg_policy.evaluation.trials); what is
handled here is a job that raises anyway (e.g. its record cannot be sent back) and a worker process that dies
(killed, out of memory, a crash in native code): ProcessPoolExecutor then breaks and fails every unfinished job.

On a break the finished records are kept and the unfinished jobs go on:
  - the jobs that were running when the pool broke (each worker leaves a marker file while it runs a job) are the
    suspects: each is re-run alone in a one-worker pool, so a job that kills its worker again is identified and
    recorded as an error (stage "worker", the BrokenProcessPool message); the others give their normal records;
  - the jobs that had not started go to a fresh pool of `workers` processes.
A break with no job running (a worker dying between jobs or before its first, e.g. in `init`) makes the first
unfinished job the suspect; when a lone worker dies before even starting its one job, the workers cannot start at
all and every unfinished job is recorded as an error with that reason (the run ends with what it has instead of
looping). Every break records at least one job, so the run ends.
KeyboardInterrupt (and any BaseException that is not an Exception) cancels the pending jobs and propagates.
"""

from __future__ import annotations

import multiprocessing as mp
import tempfile
from collections.abc import Callable, Sequence
from concurrent.futures import ProcessPoolExecutor, as_completed
from concurrent.futures.process import BrokenProcessPool
from pathlib import Path
from typing import Any

from pg_policy.evaluation.errors import describe, mark_error
from pg_policy.evaluation.trials import TrialRecord

WORKER_DIED = "process died"


def _job(marker_dir: str, trial_fn: Callable[..., tuple[int, Any]], index: int, *args: Any) -> tuple[int, Any]:
    """In a worker: run one job with a marker file `marker_dir/index` present while it runs."""
    marker = Path(marker_dir) / str(index)
    marker.touch()
    try:
        return trial_fn(index, *args)
    finally:  # not reached when the process dies: the marker then names the job it was running
        marker.unlink(missing_ok=True)


class _Run:
    """The state of one parallel run: jobs, records by index, the pool settings."""

    def __init__(self, jobs: Sequence[tuple[str, int]], plan: Any, workers: int, trial_fn: Callable[..., Any],
                 init: Callable[..., None], initargs: tuple, on_trial: Callable[[TrialRecord], None] | None,
                 marker_dir: str) -> None:
        self.jobs, self.plan, self.workers, self.trial_fn = jobs, plan, workers, trial_fn
        self.init, self.initargs, self.on_trial, self.marker_dir = init, initargs, on_trial, marker_dir
        self.results: list[TrialRecord | None] = [None] * len(jobs)

    def pool(self, workers: int) -> ProcessPoolExecutor:
        return ProcessPoolExecutor(max_workers=workers, mp_context=mp.get_context("spawn"), initializer=self.init,
                                   initargs=self.initargs)

    def submit(self, pool: ProcessPoolExecutor, i: int) -> Any:
        name, seed = self.jobs[i]
        return pool.submit(_job, self.marker_dir, self.trial_fn, i, name, seed, self.plan)

    def done(self, i: int, rec: TrialRecord) -> None:
        self.results[i] = rec
        if self.on_trial is not None:
            self.on_trial(rec)

    def failed(self, i: int, exc: BaseException | None, stage: str, text: str | None = None) -> TrialRecord:
        """The error record of job `i` (no actions: they were lost with the worker)."""
        name, seed = self.jobs[i]
        return mark_error(TrialRecord(scene=name, seed=seed), exc, stage, text)

    def running(self) -> set[int]:
        """Indices whose marker is present (they were running when the pool broke), markers removed."""
        out = set()
        for p in Path(self.marker_dir).iterdir():
            out.add(int(p.name))
            p.unlink(missing_ok=True)
        return out

    def round(self, pending: list[int]) -> tuple[list[int], set[int]]:
        """Run `pending` in one pool of `workers`; returns the unfinished jobs and those running when it broke (both
        empty unless it broke)."""
        pool = self.pool(self.workers)
        broken = False
        try:
            futures = {self.submit(pool, i): i for i in pending}
            for fut in as_completed(futures):
                i = futures[fut]
                try:
                    rec = fut.result()[1]
                except BrokenProcessPool:
                    broken = True
                    continue
                except Exception as exc:  # the job raised outside the trial (e.g. its record could not be sent)
                    rec = self.failed(i, exc, "worker")
                self.done(i, rec)
        except BaseException:
            pool.shutdown(wait=True, cancel_futures=True)
            raise
        pool.shutdown(wait=True)
        if not broken:
            return [], set()
        unfinished = [i for i in pending if self.results[i] is None]
        return unfinished, self.running() & set(unfinished)

    def isolate(self, suspects: list[int]) -> str | None:
        """Run each suspect alone in a one-worker pool (a fresh one after each break); a suspect that breaks it is
        recorded as an error. Returns the reason when a worker died before starting its job (workers cannot start;
        that job and the later suspects are left unrecorded), else None."""
        pool = None
        try:
            for i in suspects:
                pool = pool or self.pool(1)
                try:
                    rec = self.submit(pool, i).result()[1]
                except BrokenProcessPool as exc:
                    pool.shutdown(wait=True)
                    pool = None
                    if i not in self.running():
                        return f"{WORKER_DIED} before starting its trial: {describe(exc)}"
                    rec = self.failed(i, None, "worker", f"{WORKER_DIED} running this trial: {describe(exc)}")
                except Exception as exc:
                    rec = self.failed(i, exc, "worker")
                self.done(i, rec)
        finally:
            if pool is not None:
                pool.shutdown(wait=True, cancel_futures=True)
        return None


def run_parallel(jobs: Sequence[tuple[str, int]], plan: Any, workers: int, trial_fn: Callable[..., Any],
                 init: Callable[..., None], initargs: tuple = (),
                 on_trial: Callable[[TrialRecord], None] | None = None) -> list[TrialRecord]:
    """Records of `jobs` ((scene, seed) pairs of `plan`) in job order, run by `workers` spawned processes (module
    docstring); `on_trial(record)` is called as each finishes. `trial_fn` and `init` must be importable functions."""
    with tempfile.TemporaryDirectory(prefix="pg_eval_jobs_") as marker_dir:
        run = _Run(jobs, plan, workers, trial_fn, init, initargs, on_trial, marker_dir)
        pending = list(range(len(jobs)))
        while pending:
            unfinished, running = run.round(pending)
            # nothing was running (a worker died between jobs or while starting): probe with one job alone
            dead = run.isolate(sorted(running) or unfinished[:1])
            if dead is not None:  # the workers cannot start: the remaining jobs end as errors with the reason
                for i in unfinished:
                    if run.results[i] is None:
                        run.done(i, run.failed(i, None, "worker", dead))
            pending = [i for i in unfinished if run.results[i] is None]
    return [r for r in run.results if r is not None]
