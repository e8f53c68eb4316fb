"""`pushgrasp offline pack|train`: learn from recorded replay buffers where the simulator cannot run (a GPU machine).

Heavy modules (torch) are imported inside the handlers.
"""

from __future__ import annotations

import argparse
from pathlib import Path


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("offline", help="offline Q-learning from recorded replay buffers (no simulator needed)",
                       description="pack: gather training replay buffers into one .npz. train: the paper's loss on "
                                   "that experience, both nets on --device; then `pushgrasp export --run OUT`.")
    verbs = p.add_subparsers(dest="verb", metavar="VERB", required=True)
    pk = verbs.add_parser("pack", help="replay directories (RUN/STAGE/replay_grasp, replay_push) -> one .npz")
    pk.add_argument("replays", nargs="+", type=Path, help="replay buffer directories (each holds meta.json)")
    pk.add_argument("--out", type=Path, required=True, help="output .npz")
    pk.set_defaults(run=_pack)
    tr = verbs.add_parser("train", help="train both nets on a packed file; writes OUT/offline/last.pt")
    tr.add_argument("--data", type=Path, required=True, help=".npz from `pushgrasp offline pack`")
    tr.add_argument("--out", type=Path, required=True, help="run directory (checkpoint, log.csv)")
    tr.add_argument("--backbone", default="densenet121", help="lite | lite-os8 | densenet121 (default densenet121)")
    tr.add_argument("--goal", choices=("none", "mask"), default="none", help="goal input (default none)")
    tr.add_argument("--pretrained", type=Path, default=None, help="torchvision densenet121 state_dict (optional)")
    tr.add_argument("--steps", type=int, default=2000, help="optimiser steps per net (default 2000)")
    tr.add_argument("--batch", type=int, default=8, help="transitions per step and net (default 8)")
    tr.add_argument("--lr", type=float, default=1e-4, help="Adam learning rate (default 1e-4)")
    tr.add_argument("--gamma", type=float, default=0.5, help="discount of the push label (default 0.5)")
    tr.add_argument("--grasp-threshold", type=float, default=0.7, help="stored for export (default 0.7)")
    tr.add_argument("--push-budget", type=int, default=3, help="stored for export (default 3)")
    tr.add_argument("--device", default="cpu", help="torch device, e.g. cuda (default cpu)")
    tr.add_argument("--seed", type=int, default=0, help="initialisation and sampling seed (default 0)")
    tr.add_argument("--minutes", type=float, default=0.0, help="wall-clock budget, 0 = none (default 0)")
    tr.set_defaults(run=_train)


def _pack(args: argparse.Namespace) -> int:
    from pg_learning.training.offline import pack

    counts = pack(args.replays, args.out)
    print(f"wrote {args.out}: {counts['grasp']} grasps, {counts['push']} pushes")
    return 0


def _train(args: argparse.Namespace) -> int:
    from pg_learning.training.offline import OfflineConfig, OfflineTrainer
    from pg_policy.models.device import check_device

    check_device(args.device)
    if args.steps < 1 or args.batch < 1:
        raise ValueError("--steps and --batch must be >= 1")
    cfg = OfflineConfig(data=args.data, out=args.out, backbone=args.backbone, goal=args.goal,
                        pretrained=args.pretrained, steps=args.steps, batch=args.batch, lr=args.lr, gamma=args.gamma,
                        grasp_threshold=args.grasp_threshold, push_budget=args.push_budget, device=args.device,
                        seed=args.seed, minutes=args.minutes)
    print(f"checkpoint: {OfflineTrainer(cfg).run()}")
    return 0
