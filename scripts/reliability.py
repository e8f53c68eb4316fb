#!/usr/bin/env python3
"""pushgrasp fault suite, long form: starts sim.launch on a private ROS master (free loopback port, logs in a temporary
folder), runs the probes of tests/reliability (soak, concurrency, bad input, target lost, fuzz, sensor faults,
corrupt models, malformed scenes, calibration without the board, listening ports) and writes report.md and report.json
to --out. Everything it starts is stopped on
exit, Ctrl-C included. Exit status: 0 when every invariant held, 1 otherwise, 2 for bad options.

    scripts/reliability.py --out runs/reliability --soak-calls 200 --fuzz 500 --seed 1
    scripts/reliability.py --quick --out /tmp/rel        # the short form that `make test` runs
    scripts/reliability.py --help                        # every option

Runs under `source scripts/ros_env.sh` (re-executes itself under it when that was not done).
"""

from __future__ import annotations

import os
import shlex
import signal
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]


def _reexec_in_ros_env() -> None:
    """Re-run this script with the project's ROS environment (devel space, venv) when it is not active."""
    if os.environ.get("PG_REPO") and "ROS_PACKAGE_PATH" in os.environ:
        return
    env_script = REPO / "scripts" / "ros_env.sh"
    cmd = f'source "{env_script}" && exec python "{Path(__file__).resolve()}" "$@"'
    os.execvp("bash", ["bash", "-c", cmd, "reliability", *sys.argv[1:]])


def main(argv: list[str] | None = None) -> int:
    sys.path.insert(0, str(REPO / "tests"))
    from reliability import options, report, runner

    args = sys.argv[1:] if argv is None else argv
    opts = options.parse(args)  # exits 2 on bad options

    def on_term(signum: int, _frame: object) -> None:
        raise KeyboardInterrupt(f"signal {signum}")

    signal.signal(signal.SIGTERM, on_term)
    signal.signal(signal.SIGINT, signal.default_int_handler)  # also when started with SIGINT ignored (background)
    command = " ".join(shlex.quote(a) for a in ["scripts/reliability.py", *args])
    rep = runner.run(opts, command)
    md, js = report.write(rep, opts.out)
    print(f"[reliability] {'PASS' if rep.passed else 'FAIL'} in {rep.wall_s:.0f} s: {md} {js}", file=sys.stderr)
    for p in rep.probes:
        print(f"  {p.name:<12} {'PASS' if p.passed else 'FAIL'}  {p.duration_s:6.0f} s", file=sys.stderr)
    print(f"  {'cleanup':<12} {'PASS' if rep.cleanup.get('passed') else 'FAIL'}  {rep.cleanup.get('summary')}",
          file=sys.stderr)
    if rep.interrupted:
        print("[reliability] interrupted; everything it started was stopped", file=sys.stderr)
        return 130
    return 0 if rep.passed else 1


if __name__ == "__main__":
    _reexec_in_ros_env()
    sys.exit(main())
