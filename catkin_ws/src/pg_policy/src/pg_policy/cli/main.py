"""`pushgrasp`: one CLI for scenes, training, evaluation and benchmarks.

Command groups register in COMMANDS (name -> "module:function" adding a subparser); modules load lazily so
`pushgrasp --help` stays fast and never imports torch or pybullet.
"""

from __future__ import annotations

import argparse
import importlib
import sys

COMMANDS: dict[str, str] = {
    "scene": "pg_sim.cli.scene:add_parser",
    "train": "pg_policy.cli.train:add_parser",
    "export": "pg_policy.cli.export:add_parser",
    "infer": "pg_policy.cli.infer:add_parser",
    "eval": "pg_policy.cli.eval:add_parser",
    "bench": "pg_policy.cli.bench:add_parser",
    "replay": "pg_policy.cli.bag_replay:add_parser",
    "compare": "pg_policy.cli.compare:add_parser",
    "offline": "pg_policy.cli.offline:add_parser",
    "policies": "pg_policy.cli.policies:add_parser",
}


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="pushgrasp",
        description="Goal-conditioned push/grasp for a dual-arm UR5e: scenes, training, evaluation, benchmarks.",
    )
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    for target in COMMANDS.values():
        module, func = target.split(":")
        getattr(importlib.import_module(module), func)(sub)
    return parser


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return int(args.run(args) or 0)
    except (ValueError, FileNotFoundError, KeyError, ConnectionError, TimeoutError) as exc:
        print(f"pushgrasp {args.command}: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f"pushgrasp {args.command}: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
