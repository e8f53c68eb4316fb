"""Scale-out benchmark: what `pushgrasp eval --workers N` and `pushgrasp train --collectors N` gain on this machine,
and what Ray costs (start-up time, memory).

It runs the commands users run, as subprocesses, one after the other:
  - eval: `pushgrasp eval --policy lite --scenes SCENES --trials T --workers W` for each W of --workers (default 1 2),
    trials per minute from the command's wall time (Ray start-up included) and its results, checked equal across W;
  - train: `pushgrasp train --stage grasp-goal --init <shipped lite> --backbone lite-os8 --scene S --iterations I
    --collectors C` for each C of --collectors (default 0 1 2), environment steps per hour from log.csv's wall_s
    (start-up excluded) and from the command's wall time;
  - Ray: a local Ray of 2 CPUs started and stopped 3 times (median seconds to a ready actor) and the resident memory of
    Ray's own processes (GCS, raylet, idle workers) while it runs.
It prints a markdown report (CPU count, load average before each run, torch threads, versions) and writes it with the
raw figures to OUT/bench_cluster.{md,json}. Nothing else may run on the machine for the figures to mean anything.

    .venv/bin/python scripts/bench_cluster.py --out /tmp/bench_cluster
    python -m pg_learning.cli.cluster_bench --out /tmp/bench_cluster    # the same (the command line: that module)
"""

from __future__ import annotations

import csv
import json
import os
import shutil
import statistics
import subprocess
import sys
import time
from pathlib import Path

from pg_core.resources import shipped_models

PY = sys.executable
VOLATILE = ("wall_s", "think_s")


def load() -> str:
    return " ".join(f"{x:.2f}" for x in os.getloadavg())


def timed(cmd: list[str], log: Path) -> float:
    """Run `cmd` (output to `log`), raise on failure; its wall time in s."""
    print(f"$ {' '.join(cmd)}", flush=True)
    t0 = time.perf_counter()
    with log.open("w") as f:
        subprocess.run(cmd, stdout=f, stderr=subprocess.STDOUT, check=True, timeout=6 * 3600)
    return time.perf_counter() - t0


def outcomes(path: Path) -> list:
    def strip(x):
        if isinstance(x, dict):
            return {k: strip(v) for k, v in x.items() if k not in VOLATILE}
        return [strip(v) for v in x] if isinstance(x, list) else x

    return [strip(t) for t in json.loads(path.read_text())["trials"]]


def bench_eval(args, out: Path) -> dict:
    rows, first = {}, None
    for w in args.workers:
        d = out / f"eval-w{w}"
        shutil.rmtree(d, ignore_errors=True)
        before = load()
        wall = timed([PY, "-m", "pg_policy.cli.main", "eval", "--policy", "lite", "--scenes", *args.scenes,
                      "--trials", str(args.trials), "--workers", str(w), "--out", str(d), "--no-progress"],
                     out / f"eval-w{w}.log")
        trials = outcomes(d / "results.json")
        first = first if first is not None else trials
        rows[w] = {"wall_s": round(wall, 1), "trials": len(trials),
                   "trials_per_min": round(60 * len(trials) / wall, 2),
                   "load_before": before, "same_results_as_first": trials == first}
    return rows


def bench_train(args, out: Path) -> dict:
    rows = {}
    for c in args.collectors:
        d = out / f"train-c{c}"
        shutil.rmtree(d, ignore_errors=True)
        before = load()
        wall = timed([PY, "-m", "pg_policy.cli.main", "train", "--stage", "grasp-goal",
                      "--init", str(shipped_models() / "lite"), "--backbone", "lite-os8", "--scene", args.train_scene,
                      "--iterations", str(args.iterations),
                      "--threads", str(args.threads), "--seed", "5", "--checkpoint-every", "1000",
                      "--collectors", str(c), "--out", str(d)], out / f"train-c{c}.log")
        log = list(csv.DictReader((d / "grasp-goal" / "log.csv").open()))
        span = float(log[-1]["wall_s"]) - float(log[0]["wall_s"])
        rows[c] = {"wall_s": round(wall, 1), "steps": len(log),
                   "steps_per_hour": round(3600 * (len(log) - 1) / span) if span > 0 else None,
                   "steps_per_hour_with_startup": round(3600 * len(log) / wall), "load_before": before}
    return rows


RAY_PROBE = r"""
import json, subprocess, time
import ray
from pg_learning.cluster.ray_session import ray_session

@ray.remote(num_cpus=1)
class Probe:
    def ready(self):
        return 1

times, rss = [], []
for _ in range(3):
    t0 = time.perf_counter()
    with ray_session(2):
        a = Probe.remote()
        ray.get(a.ready.remote(), timeout=120)
        times.append(time.perf_counter() - t0)
        time.sleep(2)
        ps = subprocess.run(["ps", "-eo", "rss,args"], capture_output=True, text=True).stdout.splitlines()[1:]
        kinds = {"gcs_server": 0, "raylet": 0, "ray::": 0, "ray/_private": 0, "ray/dashboard": 0}
        for l in ps:
            for k in kinds:
                if k in l:
                    kinds[k] += int(l.split(None, 1)[0]) / 1024
                    break
        rss.append(kinds)
print(json.dumps({"start_to_ready_actor_s": times, "ray_rss_mib": rss}))
"""


def bench_ray() -> dict:
    res = subprocess.run([PY, "-c", RAY_PROBE], capture_output=True, text=True, check=True, timeout=900)
    raw = json.loads(res.stdout.strip().splitlines()[-1])
    return {"start_to_ready_actor_s_median": round(statistics.median(raw["start_to_ready_actor_s"]), 2),
            "ray_rss_mib_median": round(statistics.median(sum(r.values()) for r in raw["ray_rss_mib"])),
            "ray_rss_mib_by_process": {k: round(v) for k, v in raw["ray_rss_mib"][-1].items()}, "raw": raw}


def report(res: dict) -> str:
    lines = [f"# Scale-out benchmark ({res['date']})", "",
             f"{res['cpus']} CPUs, {res['machine']}, Python {res['python']}, torch {res['torch']}, "
             f"ray {res['ray_version']}; "
             f"lite policy, torch threads per worker = CPUs / workers.", ""]
    if res.get("eval"):
        base = res["eval"][min(res["eval"])]["trials_per_min"]
        lines += [f"## `pushgrasp eval` ({', '.join(res['args']['scenes'])}, {res['args']['trials']} trials each)", "",
                  "| workers | trials | wall s | trials/min | speed-up | same results | load before |",
                  "|---|---|---|---|---|---|---|"]
        for w, r in res["eval"].items():
            lines.append(f"| {w} | {r['trials']} | {r['wall_s']} | {r['trials_per_min']} | "
                         f"{r['trials_per_min'] / base:.2f}x | {r['same_results_as_first']} | {r['load_before']} |")
        lines.append("")
    if res.get("train"):
        base = res["train"][min(res["train"])]["steps_per_hour"]
        lines += [f"## `pushgrasp train --collectors C` (grasp-goal, {res['args']['train_scene']}, "
                  f"{res['args']['iterations']} iterations, learner threads {res['args']['threads']})", "",
                  "| collectors | steps | wall s | steps/hour (running) | ratio | steps/hour (with start-up) "
                  "| load before |",
                  "|---|---|---|---|---|---|---|"]
        for c, r in res["train"].items():
            ratio = f"{r['steps_per_hour'] / base:.2f}x" if base and r["steps_per_hour"] else "-"
            lines.append(f"| {c} | {r['steps']} | {r['wall_s']} | {r['steps_per_hour']} | {ratio} | "
                         f"{r['steps_per_hour_with_startup']} | {r['load_before']} |")
        lines.append("")
    if res.get("ray"):
        r = res["ray"]
        parts = ", ".join(f"{k.strip(':/')} {v}" for k, v in r["ray_rss_mib_by_process"].items())
        lines += ["## Ray itself (local, 2 CPUs)", "",
                  f"- start-up to a ready actor: {r['start_to_ready_actor_s_median']} s (median of 3)",
                  f"- resident memory of Ray's processes with one idle actor: {r['ray_rss_mib_median']} MiB "
                  f"({parts})", ""]
    return "\n".join(lines)
