"""`pushgrasp train-segmenter`: simulated views of the training families, then the click-conditioned segmenter
trained on them (both resumable), written as TorchScript to <out>/click_segmenter.pt."""

from __future__ import annotations

import argparse
from dataclasses import MISSING, fields


def add_parser(sub: argparse._SubParsersAction) -> None:
    from pg_learning.segmentation.segmenter_training import SegmenterTraining

    p = sub.add_parser(
        "train-segmenter", help="train the click-conditioned object segmenter on simulated views",
        description="Drops scenes of the training families (--collect views, each saved with the simulator's "
                    "object ids per heightmap cell), then trains the segmenter that `--target-by point` and "
                    "point requests use on the first view. Rerunning the command resumes both steps. Copy "
                    "<out>/click_segmenter.pt to pg_policy/models/click-segmenter/ to ship it.",
    )
    for f in fields(SegmenterTraining):
        default = f.default if f.default is not MISSING else None
        p.add_argument("--" + f.name.replace("_", "-"), type=type(default), default=default,
                       help=f"{f.metadata['help']} (default: {default})".replace("%", "%%"))
    p.set_defaults(run=_run)


def _run(args: argparse.Namespace) -> int:
    from pg_core.seeds import MIN_EVAL_SEED
    from pg_learning.segmentation.segmenter_training import SegmenterTraining, train
    from pg_learning.segmentation.segmenter_views import collect

    config = SegmenterTraining(**{f.name: getattr(args, f.name) for f in fields(SegmenterTraining)})
    if config.view_seed < 0 or config.view_seed + config.collect > MIN_EVAL_SEED:
        raise ValueError(f"--view-seed {config.view_seed} + --collect {config.collect} must stay below {MIN_EVAL_SEED} "
                         "(the evaluation's seeds)")
    if config.window % 32:
        raise ValueError(f"--window {config.window} must be a multiple of 32")
    if config.collect:
        collect(config.families.split(","), config.view_seed, config.collect, config.views)
    if config.steps:
        print(f"model: {train(config)}")
    return 0
