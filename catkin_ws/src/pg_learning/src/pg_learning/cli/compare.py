"""`pushgrasp compare`: several policies' `pushgrasp eval` results side by side in the paper's table layout, with
the paper's figures and (for --check) the project's targets. See pg_learning.evaluation.compare."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path


def _named(text: str) -> tuple[str, Path]:
    name, sep, folder = text.partition("=")
    if not sep or not name or not folder:
        raise argparse.ArgumentTypeError(f"expected NAME=FOLDER, got {text!r}")
    return name, Path(folder)


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("compare", help="policies' eval results side by side (paper's table layout)",
                       description="Reads every `pushgrasp eval` output folder under each FOLDER (results.json, "
                                   "else the finished trials of trials.jsonl; symbolic links followed) and writes a "
                                   "markdown report (one table per scene family, the paper's figures beside them) "
                                   "and a PNG.")
    p.add_argument("policies", nargs="+", type=_named, metavar="NAME=FOLDER",
                   help="a column name and the folder holding that policy's `pushgrasp eval` output folders")
    p.add_argument("--out", type=Path, required=True, help="markdown file to write (the PNG goes beside it)")
    p.add_argument("--check", default=None, metavar="NAME",
                   help="list where policy NAME misses the targets (per-scene C/GS, beating the others) and compare it "
                        "with each other policy trial by trial (same scene and seed; pg_learning.evaluation.paired)")
    p.set_defaults(run=_run)


def _run(args: argparse.Namespace) -> int:
    from pg_learning.evaluation import compare

    if args.out.is_dir():
        print(f"pushgrasp compare: error: --out {str(args.out)[:200]} is a folder; give the markdown file to write "
              "(e.g. FOLDER/compare.md)", file=sys.stderr)
        return 2
    policies = [compare.load_policy(name, folder) for name, folder in args.policies]
    text = compare.markdown(policies, args.check)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(text, encoding="utf-8")
    png = compare.plot(policies, args.out.with_suffix(".png"))
    print(f"wrote {args.out} and {png}")
    return 0
