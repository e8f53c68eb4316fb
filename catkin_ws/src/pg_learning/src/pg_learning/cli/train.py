"""`pushgrasp train`: one stage of the paper's curriculum (resumes when its run directory has a checkpoint)."""

from __future__ import annotations

import argparse


def add_parser(sub: argparse._SubParsersAction) -> None:
    from pg_learning.training.config import add_arguments

    p = sub.add_parser(
        "train", help="train one stage: grasp-agnostic -> grasp-goal -> push -> alternate",
        description="Self-supervised training in the PyBullet simulator. Each stage starts from the previous "
                    "stage's checkpoint in the same --out directory; rerunning a command resumes it.",
    )
    add_arguments(p)
    p.set_defaults(run=_run)


def _run(args: argparse.Namespace) -> int:
    from pg_learning.training.config import from_args
    from pg_learning.training.trainer import Trainer

    path = Trainer(from_args(args)).run()
    print(f"checkpoint: {path}")
    return 0
