"""`pushgrasp`: one CLI for scenes, training, evaluation and benchmarks.

Subcommands register in COMMANDS: name -> the package that provides it and "module:function" adding its subparser.
pg_policy's own need no simulator (export, replay, policies); the learning package pg_learning provides those that
train, evaluate or render in the simulator (train, infer, eval, bench, compare, kinds, offline), and the simulator
pg_sim `scene`. Modules load lazily, when the parser is built, so that `pushgrasp --help` stays fast and never imports
torch or pybullet, and pg_policy itself never imports pg_learning or pg_sim (the import contracts of pyproject.toml):
they are named here as strings only. On an install without them (a robot cell: pg_policy alone), their subcommands
stay listed, marked as not installed, and running one says which package it needs and exits with status 2.
"""

from __future__ import annotations

import argparse
import importlib
import sys
from collections.abc import Callable
from dataclasses import dataclass

from pg_core.cpu_kernels import pin_cpu_kernels

LEARNING = "the learning package pg_learning (simulation: pg_sim, PyBullet)"
SIMULATOR = "the simulator package pg_sim (PyBullet)"
# top-level modules whose absence makes another package's subcommand unavailable (not a bug of that package)
OPTIONAL_MODULES = ("pg_learning", "pg_sim", "pybullet", "pybullet_data")


@dataclass(frozen=True)
class Command:
    """A subcommand: the catkin package providing it, "module:function" adding its subparser, and what to install
    (in words) where that package is absent."""

    package: str
    target: str
    needs: str = ""


COMMANDS: dict[str, Command] = {
    "scene": Command("pg_sim", "pg_sim.cli.scene:add_parser", SIMULATOR),
    "train": Command("pg_learning", "pg_learning.cli.train:add_parser", LEARNING),
    "export": Command("pg_policy", "pg_policy.cli.export:add_parser"),
    "infer": Command("pg_learning", "pg_learning.cli.infer:add_parser", LEARNING),
    "eval": Command("pg_learning", "pg_learning.cli.eval:add_parser", LEARNING),
    "bench": Command("pg_learning", "pg_learning.cli.bench:add_parser", LEARNING),
    "replay": Command("pg_policy", "pg_policy.cli.bag_replay:add_parser"),
    "compare": Command("pg_learning", "pg_learning.cli.compare:add_parser", LEARNING),
    "kinds": Command("pg_learning", "pg_learning.cli.kinds:add_parser", LEARNING),
    "offline": Command("pg_learning", "pg_learning.cli.offline:add_parser", LEARNING),
    "calibrate": Command("pg_learning", "pg_learning.cli.calibrate:add_parser", LEARNING),
    "robustness": Command("pg_learning", "pg_learning.cli.robustness:add_parser", LEARNING),
    "policies": Command("pg_policy", "pg_policy.cli.policies:add_parser"),
    "train-segmenter": Command("pg_learning", "pg_learning.cli.train_segmenter:add_parser", LEARNING),
}


def load_command(cmd: Command) -> tuple[Callable[[argparse._SubParsersAction], None] | None, str | None]:
    """(the function adding the subparser, None), or (None, the missing module) when `cmd` is another package's and
    that package or the simulator is not installed. Any other import error propagates."""
    module, func = cmd.target.split(":")
    try:
        return getattr(importlib.import_module(module), func), None
    except ModuleNotFoundError as exc:
        missing = (exc.name or "").split(".")[0]
        if cmd.package == "pg_policy" or missing not in OPTIONAL_MODULES:
            raise
        return None, missing


def unavailable(name: str, cmd: Command, missing: str) -> str:
    """The error line of a subcommand whose package is not installed."""
    return (f"pushgrasp {name}: error: this subcommand needs {cmd.needs}, which is not installed here "
            f"(no module {missing!r}); this install has the runtime (pg_policy) only")


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="pushgrasp",
        description="Goal-conditioned push/grasp for a dual-arm UR5e: scenes, training, evaluation, benchmarks.",
    )
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    for name, cmd in COMMANDS.items():
        add, missing = load_command(cmd)
        if add is not None:
            add(sub)
            continue
        # listed all the same; any arguments are accepted, so that the answer is always the missing package
        p = sub.add_parser(name, add_help=False, help=f"(not installed: needs {cmd.package})")
        p.set_defaults(run=None, unavailable=unavailable(name, cmd, str(missing)))
    return parser


def main(argv: list[str] | None = None) -> int:
    pin_cpu_kernels()  # before any subcommand loads numpy: the same kernels on every machine (pg_core.cpu_kernels)
    parser = build_parser()
    args, extra = parser.parse_known_args(argv)
    if getattr(args, "unavailable", None):
        print(args.unavailable, file=sys.stderr)
        return 2
    if extra:  # what parse_args does
        parser.error(f"unrecognized arguments: {' '.join(extra)}")
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
