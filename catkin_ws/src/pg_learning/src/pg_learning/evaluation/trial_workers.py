"""Running evaluation trials in worker processes: on this machine (`workers` 1: in this process) or on Ray actors
(pg_learning.evaluation.ray_trials), each worker with its own policy and a fresh simulator per trial
(pg_learning.evaluation.runner.run_fresh). The worker functions (`worker_init`, `worker_trial`) are module functions
so that Ray's workers import them by name; model files travel to cluster nodes as bytes (`model_blobs`).
"""

from __future__ import annotations

import os
from collections.abc import Callable
from dataclasses import replace
from functools import partial
from pathlib import Path
from typing import Any

from pg_learning.evaluation.runner import EvalPlan, run_fresh, run_jobs
from pg_policy.target_loop.records import TrialRecord

_WORKER: dict[str, Any] = {}  # the policy of this worker process, made once by worker_init


def worker_threads(workers: int, cpus: int | None = None) -> int:
    """CPU threads for torch and OpenCV in each of `workers` processes: the machine's CPUs shared out, at least 1.
    Without it every worker takes all CPUs and they slow each other down (seen on a 16-core GPU machine)."""
    return max(1, (cpus or os.cpu_count() or 1) // max(1, workers))


def model_blobs(paths: Any) -> tuple[tuple[str, bytes], ...]:
    """(file name, bytes) of each model file, for workers on other machines."""
    return tuple((Path(p).name, Path(p).read_bytes()) for p in paths)


def local_models(opts: Any, blobs: tuple[tuple[str, bytes], ...]) -> Any:
    """`opts` (PolicyOptions) with its model files as they are here, or, when one is missing on this machine (a
    cluster node without the driver's files), with the copies in `blobs` written to a fresh temporary folder."""
    if not blobs or all(Path(p).is_file() for p in opts.models):
        return opts
    import tempfile

    folder = Path(tempfile.mkdtemp(prefix="pg_models_"))
    for name, data in blobs:
        (folder / name).write_bytes(data)
    return replace(opts, models=tuple(folder / name for name, _ in blobs))


def worker_init(policy: str, opts: Any, threads: int, blobs: tuple[tuple[str, bytes], ...] = ()) -> None:
    """Make this worker's policy (`policy` name with PolicyOptions `opts`) on `threads` CPU threads."""
    import cv2
    import torch

    from pg_policy.policies.registry import make_policy

    torch.set_num_threads(threads)
    cv2.setNumThreads(threads)
    _WORKER["policy"] = make_policy(policy, local_models(opts, blobs))


def sim_env_factory(plan: EvalPlan) -> Callable[[], Any]:
    """A maker of fresh simulated environments in the plan's simulation mode, colour variant and sensor profile."""
    from pg_learning.environment.sim_env import SimEnv

    return partial(SimEnv, sim_mode=plan.sim_mode, colours=plan.colours, sensor=plan.sensor, calibrate=plan.calibrate)


def worker_trial(index: int, name: str, seed: int, plan: EvalPlan) -> tuple[int, TrialRecord]:
    """(index, record) of trial (`name`, `seed`) of `plan` with this worker's policy, in a fresh simulator."""
    return index, run_fresh(sim_env_factory(plan), _WORKER["policy"], name, seed, plan)


def run_trials(policy: str, opts: Any, plan: EvalPlan, jobs: list[tuple[str, int]], workers: int,
               on_trial: Callable[[TrialRecord], None] | None = None, address: str | None = None,
               on_start: Callable[..., None] | None = None) -> list[TrialRecord]:
    """Records of `jobs` ((scene, seed) pairs of `plan`) in job order: in this process (`workers` 1, no `address`:
    run_jobs) or on Ray actors (pg_learning.evaluation.ray_trials; `workers` 0 with an address = one per
    cluster CPU). `policy` and `opts` (PolicyOptions) make the policy; `on_trial(record)` is called as each trial
    finishes. A trial that raises, or whose worker dies twice, is an error record; the others are kept."""
    if workers == 1 and address is None:
        from pg_policy.policies.registry import make_policy

        return run_jobs(sim_env_factory(plan), make_policy(policy, opts), plan, jobs, on_trial)
    from pg_learning.evaluation.ray_trials import run_on_ray

    threads = worker_threads(workers) if address is None else 1
    blobs = model_blobs(opts.models) if address is not None else ()  # the driver's models travel to the nodes
    return run_on_ray(jobs, plan, workers, worker_trial, worker_init, (policy, opts, threads, blobs), on_trial,
                      address=address, on_start=on_start)
