"""`pushgrasp export`: a training checkpoint -> one TorchScript file per net (grasp.pt, push.pt) with metadata."""

from __future__ import annotations

import argparse
from pathlib import Path

STAGE_ORDER = ("offline", "alternate", "push", "grasp-goal", "grasp-agnostic")  # offline: `pushgrasp offline`


def add_parser(sub: argparse._SubParsersAction) -> None:
    from pg_policy.decision.rules.grasp_check import NAMES as CHECKS

    p = sub.add_parser("export", help="export a run's checkpoint as TorchScript files with embedded metadata",
                       description="Writes OUT/grasp.pt and OUT/push.pt; loading them needs no project source.")
    p.add_argument("--run", dest="run_dir", type=Path, required=True,
                   help="training run directory (the --out of `pushgrasp train`)")
    p.add_argument("--stage", default=None, choices=STAGE_ORDER,
                   help="stage whose last.pt to export (default: the latest stage present)")
    p.add_argument("--out", type=Path, required=True, help="output directory for grasp.pt and push.pt")
    p.add_argument("--threshold", type=float, default=None,
                   help="grasp threshold on the masked max Q_g stored in the metadata (default: the run's)")
    p.add_argument("--push-budget", type=int, default=None,
                   help="pushes in a row after which the learned policy grasps even below the threshold, stored "
                        "in the metadata (default: the run's --push-budget, 0 = none, the paper's rule)")
    p.add_argument("--grasp-filter", default=None, metavar="SPEC",
                   help="filter applied to Q_g before the decision, stored in the metadata (rule grasp_filter: "
                        "none, sym, min3, sym+min3, ...; default: none, the paper's rule)")
    p.add_argument("--grasp-check", default=None, choices=CHECKS,
                   help="geometric check of the chosen grasp stored in the metadata (rule grasp_check; "
                        "default: none, the paper's rule)")
    p.add_argument("--edge-guard", default=None, choices=("on", "off"),
                   help="store thresholds.edge_guard: re-rank the learned push away from the workspace's edge "
                        "(pg_policy.decision.rules.edge_guard; default: not stored = off, the paper's rule)")
    p.add_argument("--push-landing", default=None, choices=("on", "off"),
                   help="store thresholds.push_landing: re-rank the learned push so the closed fingers do not "
                        "come down on top of an object (rule push_landing; default: not stored = off)")
    p.set_defaults(run=_run)


def latest_checkpoint(run: Path, stage: str | None) -> Path:
    """The checkpoint of `stage`, or of the most advanced stage present; FileNotFoundError names what is missing."""
    stages = [stage] if stage else list(STAGE_ORDER)
    for s in stages:
        ck = Path(run) / s / "last.pt"
        if ck.exists():
            return ck
    raise FileNotFoundError(f"no checkpoint for stage(s) {', '.join(stages)} under {run}")


def export_run(run: Path, out: Path, stage: str | None = None, threshold: float | None = None,
               push_budget: int | None = None, grasp_filter: str | None = None,
               grasp_check: str | None = None, edge_guard: bool | None = None,
               push_landing: bool | None = None) -> list[Path]:
    """OUT/grasp.pt and OUT/push.pt from the run's checkpoint of `stage` (default: the latest), with the decision
    parameters in the metadata's thresholds. Raises FileNotFoundError (no checkpoint), ValueError (bad
    push_budget or grasp_filter)."""
    import torch

    from pg_policy.decision.rules.grasp_filter import GraspFilter
    from pg_policy.models.model_io import export_qnet
    from pg_policy.models.nets.qnet import QNetConfig, build_qnet

    ck_path = latest_checkpoint(run, stage)
    ck = torch.load(ck_path, map_location="cpu", weights_only=False)
    cfg = ck["config"]
    qcfg = QNetConfig(backbone=cfg["backbone"], goal=cfg["goal"], rotations=int(cfg["rotations"]))
    thr = float(threshold if threshold is not None else cfg["grasp_threshold"])
    if push_budget is None:
        push_budget = int(cfg.get("push_budget", 0))
    if push_budget < 0:
        raise ValueError(f"--push-budget must be >= 0, got {push_budget}")
    thresholds = {"grasp_q": thr, "push_budget": int(push_budget)}
    if grasp_filter is not None:
        thresholds["grasp_filter"] = str(GraspFilter.parse(grasp_filter))
    if grasp_check is not None:
        thresholds["grasp_check"] = grasp_check
    for key, on in (("edge_guard", edge_guard), ("push_landing", push_landing)):
        if on is not None:
            thresholds[key] = bool(on)
    written = []
    for role in ("grasp", "push"):
        net = build_qnet(qcfg)
        net.load_state_dict(ck["nets"][role])
        meta = {"role": role, "stage": ck["stage"], "iteration": int(ck["iteration"]),
                "thresholds": thresholds, "source": str(ck_path)}
        written.append(export_qnet(net, Path(out) / f"{role}.pt", meta))
    return written


def _run(args: argparse.Namespace) -> int:
    def flag(value: str | None) -> bool | None:
        return None if value is None else value == "on"

    for path in export_run(args.run_dir, args.out, args.stage, args.threshold, args.push_budget, args.grasp_filter,
                           args.grasp_check, flag(args.edge_guard), flag(args.push_landing)):
        print(f"wrote {path}")
    return 0
