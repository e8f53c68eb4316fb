"""`pushgrasp eval`: run the evaluation protocol for a policy on scenes through the evaluation runner
(pg_learning.evaluation.runner: in this process or on Ray) and write the results (pg_learning.evaluation.report).
Heavy modules (pybullet, torch) are imported inside the handler.

Errors (unknown policy, unknown scene, missing model file, a training seed) end the command with status 2 and one
line on stderr (pg_policy.cli.main.main). An error inside a trial (the policy or the simulator raising, a worker
process dying) does not: that trial ends with termination "error" and its reason, the run goes on, and the results
are written with the errors counted and listed (pg_learning.evaluation.errors, pg_learning.evaluation.ray_trials).

Every finished trial goes to OUT/trials.jsonl as it ends (pg_learning.evaluation.journal): after Ctrl-C or a lost
machine, the same command runs only the missing trials; the results cover them all.
"""

from __future__ import annotations

import argparse
import math
import os
import time
from pathlib import Path
from typing import Any

from pg_core.cpu_kernels import kernels_in_effect
from pg_core.seeds import MIN_EVAL_SEED
from pg_learning.evaluation.runner import DEFAULT_JITTER_XY, DEFAULT_JITTER_YAW, DEFAULT_SEED
from pg_learning.evaluation.target_by import COLOUR, TARGET_BY, check_target_by
from pg_policy.policies import options
from pg_policy.target_loop.episode import DEFAULT_MAX_ACTIONS, DEFAULT_MAX_FAILED_GRASPS
from pg_sim.world.recolour import COLOUR_MODES, UNIQUE
from pg_sim.world.sensor_model import PERFECT
from pg_sim.world.sim_mode import DEFAULT_SIM_MODE, SIM_MODES


def add_sensor_argument(parser: argparse.ArgumentParser) -> None:
    """--sensor NAME_OR_YAML: the simulated camera's sensor profile (pg_sim.world.sensor_model)."""
    parser.add_argument("--sensor", default=PERFECT,
                        help=f"sensor profile of the simulated camera (default {PERFECT}: exact depth, the "
                             "configured pose): d435, d415 (depth noise, holes, colour gains, pose error; "
                             "pg_sim/config/sensors) or a YAML file of the same keys")


def add_parser(sub: argparse._SubParsersAction) -> None:
    ev = sub.add_parser(
        "eval", help="evaluate a policy on scenes (completion, grasp success, motion number; DESIGN.md section 8)",
        description="Run trials of a policy and write results.json, results.md (C, GS, MN per scene) and results.png.",
    )
    ev.add_argument("--policy", default="lite",
                    help="registered policy (random, heuristic, grasp-only, learned), a shipped model folder name, "
                         "or a model directory/file (a directory with grasp.pt and push.pt runs `learned`, grasp.pt "
                         "alone `grasp-only`) (default: lite, the shipped model)")
    ev.add_argument("--model", nargs="+", type=Path, default=[],
                    help="models of grasp-only/learned: a directory with grasp.pt [push.pt], or grasp.pt [push.pt]")
    ev.add_argument("--scenes", nargs="+", required=True,
                    help="packed, household, generated families from the trial seed (random-N; novel-N, "
                         "novel-packed-N, mixed-N of held-out objects; `pushgrasp scene list`), scene names "
                         "(packed/case01) or scene YAML files")
    ev.add_argument("--trials", type=int, required=True, help="trials per scene")
    ev.add_argument("--seed", type=int, default=DEFAULT_SEED,
                    help=f"trial i uses seed SEED + i (default {DEFAULT_SEED}; must be >= {MIN_EVAL_SEED}: "
                         "training uses the seeds below)")
    ev.add_argument("--allow-train-seeds", action="store_true", help=f"accept --seed below {MIN_EVAL_SEED}")
    ev.add_argument("--out", type=Path, required=True, help="output directory")
    ev.add_argument("--max-actions", type=int, default=DEFAULT_MAX_ACTIONS,
                    help=f"action budget per trial (default {DEFAULT_MAX_ACTIONS})")
    ev.add_argument("--max-failed-grasps", type=int, default=DEFAULT_MAX_FAILED_GRASPS,
                    help=f"failed grasp attempts that end a trial (default {DEFAULT_MAX_FAILED_GRASPS})")
    ev.add_argument("--jitter-xy", type=float, default=DEFAULT_JITTER_XY,
                    help=f"fixed scenes: seeded rigid shift of the whole scene, uniform +- m (default "
                         f"{DEFAULT_JITTER_XY}; 0 with --jitter-yaw 0 = the exact file)")
    ev.add_argument("--jitter-yaw", type=float, default=math.degrees(DEFAULT_JITTER_YAW),
                    help=f"fixed scenes: seeded rigid rotation of the whole scene, uniform +- deg (default "
                         f"{math.degrees(DEFAULT_JITTER_YAW)})")
    ev.add_argument("--target-by", choices=list(TARGET_BY), default=COLOUR,
                    help="how each trial names its target (default colour): colour = its palette colour; point = "
                         "the point at the centre of the target in the first view; mask = its mask in the first "
                         "view (both from the simulator's ground truth, then followed by the target tracker: "
                         "results add the tracked mask's IoU and grasps of the wrong object)")
    ev.add_argument("--segmenter", default="none",
                    help="point targets: the learned segmenter that joins the parts of the object under the point "
                         "(default none: the geometric segmentation alone; shipped: "
                         "pg_policy/models/click-segmenter; or the path of a model file from `pushgrasp "
                         "train-segmenter`)")
    ev.add_argument("--colours", choices=list(COLOUR_MODES), default=UNIQUE,
                    help="scene colours (default unique: as built, the target's colour its own): repeated = "
                         "random palette colours with duplicates, at least one other object in the target's "
                         "colour; same = every object one colour (drawn from the trial seed; needs --target-by "
                         "point or mask)")
    ev.add_argument("--sim-mode", choices=list(SIM_MODES), default=DEFAULT_SIM_MODE,
                    help=f"simulation mode (default {DEFAULT_SIM_MODE}): fast teleports the arms through free space "
                         "and gives the table its own static body; faithful steps every motion (docs/RESULTS.md "
                         "compares them on the protocol)")
    add_sensor_argument(ev)
    ev.add_argument("--calibrate", action="store_true",
                    help="calibrate the simulated camera before every trial (the ChArUco hand-eye calibration of "
                         "`pushgrasp calibrate --sim`, in the trial's empty world) and build the heightmaps from the "
                         "calibrated pose: what a --sensor pose error costs after a calibration")
    options.add_arguments(ev)  # the declared policy options: --grasp-threshold, --rules, --grasp-check, ...
    ev.add_argument("--device", default="cpu", help="torch device of learned policies (default cpu)")
    ev.add_argument("--workers", type=int, default=None,
                    help="trials run at once: N > 1 starts a local Ray with N workers (default 1: in this "
                         "process; with --ray-address: one per CPU of the cluster); results do not depend on it")
    ev.add_argument("--ray-address", default=None,
                    help="run the workers on a Ray cluster: auto (the cluster started on this machine with "
                         "`ray start --head`) or HOST:PORT of its head (docs/CLUSTER.md)")
    ev.add_argument("--fresh", action="store_true",
                    help="discard the finished trials of an earlier run in --out (default: a re-run of the same "
                         "command resumes from OUT/trials.jsonl)")
    ev.add_argument("--no-progress", action="store_true", help="no progress bar")
    ev.set_defaults(run=_run)


def _run(args: argparse.Namespace) -> int:
    from dataclasses import asdict, replace

    from tqdm import tqdm

    from pg_core.geometry import load as load_geometry
    from pg_learning.evaluation.errors import reason_lines
    from pg_learning.evaluation.journal import TrialJournal, file_digests
    from pg_learning.evaluation.report import git_commit, write_results
    from pg_learning.evaluation.runner import EvalPlan, Limits, check_seed, expand_scenes
    from pg_learning.evaluation.trial_workers import run_trials
    from pg_policy.decision.rules.pipeline import RulePipeline
    from pg_policy.models.click_segmentation import DEFAULT_SEGMENTER, load_segmenter
    from pg_policy.models.device import check_device
    from pg_policy.policies.policy import PolicyOptions
    from pg_policy.policies.registry import make_policy
    from pg_policy.target_loop.episode import ERROR, TARGET_LOST, TARGET_NOT_FOUND
    from pg_sim.world.sensor_model import load_profile

    check_seed(args.seed, args.allow_train_seeds)
    check_target_by(args.target_by, args.colours)
    check_device(args.device)
    load_profile(args.sensor)  # ValueError naming the known profiles before any simulation
    load_segmenter(args.segmenter)  # FileNotFoundError naming the accepted values before any simulation
    if args.trials < 1:
        raise ValueError(f"--trials must be >= 1, got {args.trials}")
    workers = args.workers if args.workers is not None else (0 if args.ray_address else 1)
    if workers < 0 or (workers == 0 and not args.ray_address):
        raise ValueError(f"--workers must be >= 1 (0 = one per cluster CPU, with --ray-address), got {workers}")
    if args.jitter_xy < 0 or args.jitter_yaw < 0:
        raise ValueError("--jitter-xy and --jitter-yaw must be >= 0")
    scenes = expand_scenes(args.scenes)
    geometry = load_geometry()  # $PG_WORKSPACE_CONFIG or the package's; the simulator workers load the same file
    opts = PolicyOptions(models=tuple(args.model), seed=args.seed, device=args.device,
                         overrides=options.from_args(args))
    policy = make_policy(args.policy, opts)  # validates the name and the model files before any simulation
    paths = getattr(policy, "model_paths", None)
    if paths:  # workers and the record get the resolved files
        opts = replace(opts, models=tuple(paths))
    policy_name = getattr(policy, "name", args.policy)
    # what each worker makes: a model path became the learned/grasp-only policy with its files in opts.models
    worker_policy = policy_name if paths else args.policy
    rules = getattr(policy, "rules", None)  # the rule list as resolved (options, else the model's)
    rules = rules if isinstance(rules, RulePipeline) else None
    del policy
    plan = EvalPlan(tuple(scenes), args.trials, args.seed, Limits(args.max_actions, args.max_failed_grasps),
                    args.jitter_xy, math.radians(args.jitter_yaw), args.sim_mode, args.target_by, args.colours,
                    args.sensor, args.calibrate, args.segmenter)
    config = {
        "policy": policy_name, "policy_arg": args.policy, "models": [str(p) for p in opts.models],
        "scenes": scenes, "trials": args.trials,
        "seed": args.seed, "trial_seeds": f"seed + i for trial i = 0..{args.trials - 1}",
        "max_actions": args.max_actions, "max_failed_grasps": args.max_failed_grasps,
        "jitter_xy_m": args.jitter_xy, "jitter_yaw_deg": args.jitter_yaw, "sim_mode": args.sim_mode,
        "options": dict(opts.overrides),
        "rules": None if rules is None else rules.specs(),
        "geometry_config": str(geometry.path), "primitives": asdict(geometry.primitives),
        "model_sha256": file_digests([str(p) for p in opts.models]),
        "git_commit": git_commit(), "started": time.strftime("%Y-%m-%dT%H:%M:%S%z"), "workers": workers,
        "host_cpus": os.cpu_count(), "ray": args.ray_address, "cpu_kernels": kernels_in_effect(),
    }
    if args.target_by != COLOUR or args.colours != UNIQUE:  # absent by default: earlier journals stay resumable
        config.update(target_by=args.target_by, colours=args.colours)
    if args.segmenter != DEFAULT_SEGMENTER:  # absent by default, as above
        config.update(segmenter=args.segmenter)
    if args.sensor != PERFECT:  # absent by default, as above
        config.update(sensor=args.sensor)
    if args.calibrate:
        config.update(calibrate=True)
    jobs = plan.jobs()
    journal = TrialJournal(args.out, config, fresh=args.fresh)
    pending = journal.pending(jobs)
    config["resumed_trials"] = len(jobs) - len(pending)
    done: list[Any] = journal.records(jobs)
    if done:
        print(f"resuming: {len(done)} of {len(jobs)} trials are in {journal.path} (--fresh discards them)")
    bar = tqdm(total=len(jobs), initial=len(done), desc=f"eval {policy_name}", unit="trial",
               disable=args.no_progress)
    t0 = time.perf_counter()
    ran = [0]

    def on_start(info: Any, actors: int) -> None:
        print(f"Ray: {actors} workers on {info.address} ({info.nodes} nodes, {info.cpus} CPUs)")

    def on_trial(rec: Any) -> None:
        journal.add(rec)
        ran[0] += 1
        done.append(rec)
        graspers = [t.grasp_success for t in done if t.grasp_success is not None]
        gs = f"{100 * sum(graspers) / len(graspers):.0f}%" if graspers else "n/a"
        n_err = sum(t.termination == ERROR for t in done)
        n_lost = sum(t.termination == TARGET_LOST for t in done)
        n_nf = sum(t.termination == TARGET_NOT_FOUND for t in done)
        errs = ((f" errors {n_err}" if n_err else "") + (f" lost {n_lost}" if n_lost else "")
                + (f" not found {n_nf}" if n_nf else ""))
        rate = 60 * ran[0] / max(1e-9, time.perf_counter() - t0)
        bar.set_postfix_str(f"{rate:.1f} trials/min C {100 * sum(t.completed for t in done) / len(done):.0f}% "
                            f"GS {gs}{errs} last {rec.scene}")
        bar.update(1)

    try:
        run_trials(worker_policy, opts, plan, [jobs[i] for i in pending], workers, on_trial, args.ray_address,
                   on_start)
    except KeyboardInterrupt:
        bar.close()
        print(f"interrupted: {len(journal.done)} of {len(jobs)} trials are kept in {journal.path}; the same command "
              "resumes the run")
        raise
    finally:
        bar.close()
    trials = journal.records(jobs)
    config["wall_s"] = round(time.perf_counter() - t0, 1)
    paths = write_results(args.out, trials, config)
    print(paths["md"].read_text(encoding="utf-8").split("\n\nC: ")[0])  # the table and the error reasons
    if reason_lines(trials):
        import sys

        print(f"{sum(t.termination == ERROR for t in trials)} of {len(trials)} trials ended in an error: see "
              f"{paths['md']} and the trials' error / error_at / error_trace in {paths['json']}", file=sys.stderr)
    print(f"wrote {', '.join(str(p) for p in paths.values())}")
    return 0
