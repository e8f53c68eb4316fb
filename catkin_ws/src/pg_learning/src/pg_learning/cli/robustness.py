"""`pushgrasp robustness`: what camera noise and calibration error cost, as a table made by one command.

Runs `pushgrasp eval` for every policy and camera condition (pg_learning.evaluation.robustness.CONDITIONS) on the
same scenes and seeds into OUT/<policy>/<condition>/, then writes OUT/robustness.md: C and GS per family and
condition, paired with the perfect camera on the same trials. Re-running the command resumes the runs it finds
(each eval folder's journal); `--table-only` rebuilds the table from what is there.
"""

from __future__ import annotations

import argparse
from pathlib import Path

DESCRIPTION = "C and GS under camera noise and calibration error, paired with the perfect camera."
DEFAULT_SCENES = ("packed", "random-15", "novel-10")
DEFAULT_POLICIES = ("lite", "heuristic")


def _arguments(parser: argparse.ArgumentParser) -> None:
    from pg_learning.evaluation.robustness import CONDITIONS

    parser.add_argument("--policies", nargs="+", default=list(DEFAULT_POLICIES),
                        help=f"policies to run (default {' '.join(DEFAULT_POLICIES)}; any `pushgrasp eval --policy`)")
    parser.add_argument("--scenes", nargs="+", default=list(DEFAULT_SCENES),
                        help=f"scenes or families as `pushgrasp eval --scenes` takes them (default "
                             f"{' '.join(DEFAULT_SCENES)})")
    parser.add_argument("--conditions", nargs="+", default=list(CONDITIONS), choices=list(CONDITIONS),
                        metavar="CONDITION",
                        help="camera conditions (default all: " + "; ".join(f"{n}: {c.what}" for n, c in
                                                                          CONDITIONS.items()) + ")")
    parser.add_argument("--trials", type=int, default=30, help="trials per scene (default 30)")
    parser.add_argument("--seed", type=int, default=None, help="first trial seed (default: pushgrasp eval's)")
    parser.add_argument("--workers", type=int, default=1, help="trials at once per run (default 1)")
    parser.add_argument("--out", type=Path, required=True, help="folder of the runs and of robustness.md")
    parser.add_argument("--table-only", action="store_true", help="only rebuild OUT/robustness.md from the runs")
    parser.add_argument("--no-progress", action="store_true", help="no progress bars")
    parser.set_defaults(run=_run)


def add_parser(sub: argparse._SubParsersAction) -> None:
    _arguments(sub.add_parser("robustness", help="C and GS under camera noise and calibration error",
                              description=DESCRIPTION))


def _run(args: argparse.Namespace) -> int:
    from pg_learning.evaluation.robustness import CONDITIONS, check_conditions, table
    from pg_policy.cli.main import main as pushgrasp

    conditions = check_conditions(args.conditions)
    if args.trials < 1:
        raise ValueError(f"--trials must be >= 1, got {args.trials}")
    if not args.table_only:
        for policy in args.policies:
            for name in conditions:
                out = args.out / policy / name
                print(f"[robustness] {policy}, {name}: {CONDITIONS[name].what} -> {out}", flush=True)
                argv = ["eval", "--policy", policy, "--scenes", *args.scenes, "--trials", str(args.trials),
                        "--workers", str(args.workers), "--out", str(out), *CONDITIONS[name].eval_args()]
                argv += ["--seed", str(args.seed)] if args.seed is not None else []
                argv += ["--no-progress"] if args.no_progress else []
                status = pushgrasp(argv)
                if status not in (0, None):
                    print(f"[robustness] {policy}, {name}: pushgrasp eval ended with status {status}", flush=True)
    text = table(args.out, args.policies, conditions)
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "robustness.md").write_text(text, encoding="utf-8")
    print(text)
    print(f"wrote {args.out / 'robustness.md'}")
    return 0


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="pushgrasp robustness", description=DESCRIPTION)
    _arguments(parser)
    args = parser.parse_args(argv)
    return int(args.run(args))


if __name__ == "__main__":
    raise SystemExit(main())
