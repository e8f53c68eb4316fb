"""`pushgrasp bench`: the shipped policy's decision end to end by stage, then the decision latency of each net variant
next to a VPG-style loop, with decision agreement.

Heavy modules (torch, pybullet) are imported inside the handler.
"""

from __future__ import annotations

import argparse


def _csv(text: str) -> list[str]:
    return [t.strip() for t in text.split(",") if t.strip()]


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("bench", help="decision latency (heightmap -> decision) per variant vs a VPG-style loop")
    p.add_argument("--variants", type=_csv, default=["lite", "lite-os8", "densenet121"],
                   help="comma-separated backbones of the nets-only modes (default lite,lite-os8,densenet121); "
                        "\"\" skips them")
    p.add_argument("--modes", type=_csv, default=None,
                   help="comma-separated modes (default all: vpg-loop,batched,early-grasp,window,window+early)")
    p.add_argument("--runs", type=int, default=20, help="timed decisions per mode (median reported, default 20)")
    p.add_argument("--threads", type=int, default=2, help="torch CPU threads (default 2)")
    p.add_argument("--scenes", type=_csv, default=None,
                   help="comma-separated shipped scenes for the inputs (default: all, see `pushgrasp scene list`)")
    p.add_argument("--threshold", type=float, default=1.8, help="grasp threshold on the masked max Q_g (default 1.8)")
    p.add_argument("--window-margin", type=float, default=None,
                   help="window modes: context (m) around the push region; default: the backbone's exact margin "
                        "(lite), else 0.1")
    p.add_argument("--goal", choices=("none", "mask"), default="mask", help="net variant's goal input (default mask)")
    p.add_argument("--seed", type=int, default=0, help="weight initialisation seed (default 0)")
    p.add_argument("--no-optimize", action="store_true",
                   help="time the eager nets instead of frozen TorchScript copies (as deployed)")
    p.add_argument("--device", default="cpu", help="torch device of the nets, e.g. cuda (default cpu)")
    p.add_argument("--cases", default=None, metavar="NPZ",
                   help="heightmaps + target masks from --save-cases instead of rendering the shipped scenes "
                        "(for a machine without the simulator)")
    p.add_argument("--save-cases", default=None, metavar="NPZ",
                   help="render the shipped scenes (--scenes), write their heightmaps and masks to NPZ and exit")
    p.add_argument("--policy", default="lite",
                   help="time this policy's act() end to end with a per-stage breakdown before the net variants: "
                        "a policy name, model dir or plugin (default lite, the shipped policy); none: skip")
    p.add_argument("--policy-scenes", type=_csv, default=None,
                   help="comma-separated shipped scenes whose first views the policy decides on (default "
                        "packed/case01,packed/case05,packed/case09,household/case12)")
    p.add_argument("--policy-runs", type=int, default=10,
                   help="rounds over the policy scenes (median over all calls reported, default 10)")
    p.add_argument("--quiet", action="store_true", help="no per-mode progress on stderr")
    p.set_defaults(run=_run)


def _run(args: argparse.Namespace) -> int:
    from pg_learning.evaluation.bench import MODES, run, save_cases, scene_cases

    if args.save_cases:
        cases = scene_cases(args.scenes)
        save_cases(cases, args.save_cases)
        print(f"wrote {len(cases)} heightmaps to {args.save_cases}")
        return 0
    if args.policy != "none":
        from pg_learning.evaluation.policy_bench import DEFAULT_SCENES, bench_policy, same_decisions

        scenes = args.policy_scenes or DEFAULT_SCENES
        pb = bench_policy(args.policy, scenes, runs=args.policy_runs, threads=args.threads, verbose=not args.quiet)
        print(pb.report() + "\n")
        if "nets" in pb.stages_s:  # a learned policy: the same decisions from the full Q maps, for comparison
            full = bench_policy(args.policy, scenes, runs=args.policy_runs, threads=args.threads,
                                verbose=not args.quiet, overrides={"q_window": False})
            print(full.report())
            print(f"\nq_window on / off: {pb.median_ms():.1f} / {full.median_ms():.1f} ms; same decisions: "
                  f"{'yes' if same_decisions(pb, full) else 'NO'}\n")
    if not args.variants:
        return 0
    result = run(args.variants, runs=args.runs, threads=args.threads, scenes=args.scenes,
                 modes=args.modes or tuple(MODES), threshold=args.threshold, margin_m=args.window_margin,
                 seed=args.seed, goal=args.goal, optimize=not args.no_optimize, verbose=not args.quiet,
                 device=args.device, cases_file=args.cases)
    print(result.report())
    return 0
