"""`pushgrasp export`: a training checkpoint -> one TorchScript file per net (grasp.pt, push.pt) with metadata."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from pg_policy.decision.option import PolicyOption
from pg_policy.policies import options

STAGE_ORDER = ("offline", "alternate", "push", "grasp-goal", "grasp-agnostic")  # offline: `pushgrasp offline`
BASE_RULES = ("failed_grasps:0.01",)  # the paper's decision plus the failed-grasp memory; options add the others


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("export", help="export a run's checkpoint as TorchScript files with embedded metadata",
                       description="Writes OUT/grasp.pt and OUT/push.pt; loading them needs no project source.")
    p.add_argument("--run", dest="run_dir", type=Path, required=True,
                   help="training run directory (the --out of `pushgrasp train`)")
    p.add_argument("--stage", default=None, choices=STAGE_ORDER,
                   help="stage whose last.pt to export (default: the latest stage present)")
    p.add_argument("--out", type=Path, required=True, help="output directory for grasp.pt and push.pt")
    options.add_arguments(p, unset=_unset, model_only=True)
    p.set_defaults(run=_run)


def _unset(o: PolicyOption) -> str:
    """What export writes for an unset model option: the run's threshold and budget, else the base rule list."""
    if o.name in ("grasp_threshold", "push_budget"):
        return "the run's"
    return f"as in the base rule list {','.join(BASE_RULES)}"


def latest_checkpoint(run: Path, stage: str | None) -> Path:
    """The checkpoint of `stage`, or of the most advanced stage present; FileNotFoundError names what is missing."""
    stages = [stage] if stage else list(STAGE_ORDER)
    for s in stages:
        ck = Path(run) / s / "last.pt"
        if ck.exists():
            return ck
    raise FileNotFoundError(f"no checkpoint for stage(s) {', '.join(stages)} under {run}")


def export_run(run: Path, out: Path, stage: str | None = None, overrides: dict[str, Any] | None = None) -> list[Path]:
    """OUT/grasp.pt and OUT/push.pt from the run's checkpoint of `stage` (default: the latest), with the decision
    values (thresholds.grasp_q, thresholds.push_budget: `overrides` else the run's) and the rule list (BASE_RULES
    edited by the rule options of `overrides`, pg_policy.policies.options) in the metadata. Raises
    FileNotFoundError (no checkpoint), ValueError (a bad option value or rule list)."""

    from pg_core.geometry import load as load_geometry
    from pg_policy.decision.rules.registry import make_pipeline
    from pg_policy.models.checkpoint import load_checkpoint
    from pg_policy.models.model_io import export_qnet
    from pg_policy.models.nets.qnet import QNetConfig, build_qnet

    overrides = dict(overrides or {})
    # every option and rule argument is validated (and written in its canonical form) before anything is written
    rules = make_pipeline(options.resolved_rules(BASE_RULES, overrides), load_geometry()).specs()
    ck_path = latest_checkpoint(run, stage)
    ck = load_checkpoint(ck_path)
    cfg = ck["config"]
    qcfg = QNetConfig(backbone=cfg["backbone"], goal=cfg["goal"], rotations=int(cfg["rotations"]))
    threshold, push_budget = overrides.get("grasp_threshold"), overrides.get("push_budget")
    thr = float(threshold if threshold is not None else cfg["grasp_threshold"])
    push_budget = int(cfg.get("push_budget", 0) if push_budget is None else push_budget)
    if push_budget < 0:
        raise ValueError(f"--push-budget must be >= 0, got {push_budget}")
    thresholds = {"grasp_q": thr, "push_budget": push_budget}
    written = []
    for role in ("grasp", "push"):
        net = build_qnet(qcfg)
        net.load_state_dict(ck["nets"][role])
        meta = {"role": role, "stage": ck["stage"], "iteration": int(ck["iteration"]),
                "thresholds": thresholds, "rules": rules, "source": str(ck_path)}
        written.append(export_qnet(net, Path(out) / f"{role}.pt", meta))
    return written


def _run(args: argparse.Namespace) -> int:
    for path in export_run(args.run_dir, args.out, args.stage, options.from_args(args)):
        print(f"wrote {path}")
    return 0
