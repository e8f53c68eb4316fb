"""The command line of the scale-out benchmark (pg_learning.evaluation.cluster_bench): `scripts/bench_cluster.py` or
`python -m pg_learning.cli.cluster_bench --out DIR` (`--help` lists the options)."""

from __future__ import annotations

import argparse
import json
import os
import platform
import sys
import time
from pathlib import Path

from pg_learning.evaluation import cluster_bench
from pg_learning.evaluation.cluster_bench import bench_eval, bench_ray, bench_train, report


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=cluster_bench.__doc__.split("\n\n")[0])
    p.add_argument("--out", type=Path, required=True, help="directory for runs, logs and the report")
    p.add_argument("--scenes", nargs="+", default=["packed", "household", "random-10", "random-15", "random-20"],
                   help="eval scenes (default: the protocol's 16, packed household random-10 random-15 random-20)")
    p.add_argument("--trials", type=int, default=2, help="eval trials per scene (default 2)")
    p.add_argument("--workers", type=int, nargs="+", default=[1, 2], help="eval workers to compare (default 1 2)")
    p.add_argument("--collectors", type=int, nargs="+", default=[0, 1, 2], help="collectors to compare (default 0 1 2)")
    p.add_argument("--iterations", type=int, default=40, help="training iterations per run (default 40)")
    p.add_argument("--train-scene", default="random-10", help="training scene family (default random-10)")
    p.add_argument("--threads", type=int, default=1, help="learner torch threads (default 1)")
    p.add_argument("--skip", nargs="*", default=[], choices=("eval", "train", "ray"), help="parts to leave out")
    args = p.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    import ray
    import torch

    res = {"date": time.strftime("%Y-%m-%d %H:%M"), "cpus": os.cpu_count(), "machine": platform.machine(),
           "python": platform.python_version(), "torch": torch.__version__, "ray_version": ray.__version__,
           "args": {k: (str(v) if isinstance(v, Path) else v) for k, v in vars(args).items()}}
    if "ray" not in args.skip:
        res["ray"] = bench_ray()
    if "eval" not in args.skip:
        res["eval"] = bench_eval(args, args.out)
    if "train" not in args.skip:
        res["train"] = bench_train(args, args.out)
    text = report(res)
    (args.out / "bench_cluster.md").write_text(text + "\n")
    (args.out / "bench_cluster.json").write_text(json.dumps(res, indent=2))
    print(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
