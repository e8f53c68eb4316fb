"""`pushgrasp kinds RUN [...]`: C, GS and MN per kind of target of saved `pushgrasp eval` runs
(pg_learning.evaluation.kinds); `python -m pg_learning.cli.kinds` runs the same command.

RUN is a results.json or an output folder of `pushgrasp eval` (its results.json, or the trials.jsonl of a run still
going or stopped). ``--pooled NAME=RUN[,RUN...] [...]`` pools the scenes of each named set of runs and prints one
table, a row per kind and a column per name (a RUN may also be a folder of output folders, e.g. results/novel/lite).
An unreadable run ends the command with status 2 and one line on stderr.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from pathlib import Path

DESCRIPTION = "C, GS and MN per kind of target of saved `pushgrasp eval` runs."


def _arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("runs", nargs="+", type=Path,
                        help="results.json files or `pushgrasp eval` output folders (a folder without results.json: "
                             "the finished trials of its trials.jsonl)")
    parser.add_argument("--pooled", action="store_true",
                        help="runs are NAME=RUN[,RUN...] (a RUN may be a folder of output folders): one table, a "
                             "row per kind and a column per NAME, the scenes of each NAME pooled")
    parser.add_argument("--by", choices=("kind", "arrangement"), default="kind",
                        help="with --pooled: a row per kind of target (kind) or per arrangement of the target in the "
                             "hard household families (arrangement: under, inside, holding, leaning, thin, edge)")
    parser.set_defaults(run=_run)


def add_parser(sub: argparse._SubParsersAction) -> None:
    _arguments(sub.add_parser("kinds", help="C, GS and MN per kind of target of saved eval runs",
                              description=DESCRIPTION))


def _named(arg: str) -> tuple[str, list[Path]]:
    """('NAME', [RUN, ...]) of a --pooled argument NAME=RUN[,RUN...] (NAME defaults to the first RUN)."""
    name, sep, runs = arg.partition("=")
    if not sep:
        name, runs = arg, arg
    paths = [Path(r) for r in runs.split(",") if r]
    if not name or not paths:
        raise ValueError(f"'{arg}': expected NAME=RUN[,RUN...]")
    return name, paths


def _run(args: argparse.Namespace) -> int:
    from pg_learning.evaluation.kinds import kind_lines, pooled_lines
    from pg_learning.evaluation.saved_runs import load_tree, load_trials

    if args.pooled:
        try:
            named = [(name, [t for p in paths for t in load_tree(p)])
                     for name, paths in (_named(str(a)) for a in args.runs)]
        except (OSError, ValueError, KeyError) as exc:
            print(f"error: {exc}", file=sys.stderr)
            return 2
        print("\n".join(pooled_lines(named, args.by)) or f"(no trials with a {args.by})")
        return 0
    for path in args.runs:
        try:
            trials = load_trials(path)
        except (OSError, ValueError, KeyError) as exc:
            print(f"error: {path}: {exc}", file=sys.stderr)
            return 2
        print(f"## {path} ({len(trials)} trials)\n")
        print("\n".join(kind_lines(trials)) or "(no catalogue-family trials)")
    return 0


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m pg_learning.cli.kinds", description=DESCRIPTION)
    _arguments(parser)
    args = parser.parse_args(argv)
    return _run(args)


if __name__ == "__main__":
    sys.exit(main())
