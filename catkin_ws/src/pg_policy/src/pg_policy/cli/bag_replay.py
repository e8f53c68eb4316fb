"""`pushgrasp replay BAG`: C/GS/MN of a recorded experiment and decision agreement of a policy re-run on it."""

from __future__ import annotations

import argparse
import json
from pathlib import Path


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("replay", help="metrics and decision agreement from a bag recorded with launch/record.launch",
                       description="Recomputes C, GS and MN (DESIGN.md section 8) from the bag's /pg/decisions and "
                                   "re-runs inference on the recorded /pg/heightmap messages, reporting agreement "
                                   "with the recorded decisions. Needs no ROS master.")
    p.add_argument("bag", type=Path, help="bag file")
    p.add_argument("--policy", default=None,
                   help="policy to re-run (default: the one that recorded each decision); a registry name or model")
    p.add_argument("--no-inference", action="store_true", help="metrics only")
    p.add_argument("--json", type=Path, default=None, help="also write the report as JSON here")
    p.set_defaults(run=_run)


def _fmt(stat) -> str:
    if stat.mean is None:
        return "-"
    return f"{stat.mean:.3f}" + (f" +- {stat.se:.3f}" if stat.se is not None else "") + f" (n={stat.n})"


def _run(args: argparse.Namespace) -> int:
    from pg_policy.policies.registry import make_policy
    from pg_policy.ros.bag_replay import replay

    rep = replay(args.bag, None if args.no_inference else make_policy, args.policy)
    print(f"{args.bag}: {rep.decisions} decisions in {len(rep.episodes)} episode(s)")
    for ep, rec in sorted(rep.episodes.items()):
        print(f"  episode {ep}: {'completed' if rec.completed else 'not completed'}, {rec.grasps} grasps "
              f"({rec.target_grasps} of the target), {rec.pushes} pushes, {rec.refused} refused")
    for key in ("C", "GS", "MN"):
        print(f"  {key}: {_fmt(rep.metrics[key])}")
    if not args.no_inference:
        agree = "-" if rep.agreement is None else f"{100 * rep.agreement:.1f} %"
        print(f"  decision agreement: {agree} ({rep.agreed}/{rep.compared}; "
              f"{rep.missing_heightmaps} decisions without their heightmap in the bag)")
        for line in rep.disagreements[:20]:
            print(f"    {line}")
    if args.json:
        from pg_policy.target_loop.records import plain

        report = {"bag": str(args.bag), "decisions": rep.decisions, "agreement": rep.agreement,
                  "compared": rep.compared, "agreed": rep.agreed, "missing_heightmaps": rep.missing_heightmaps,
                  "metrics": plain(rep.metrics), "episodes": {k: plain(v) for k, v in rep.episodes.items()},
                  "disagreements": rep.disagreements}
        args.json.parent.mkdir(parents=True, exist_ok=True)
        args.json.write_text(json.dumps(report, indent=2))
    return 0
