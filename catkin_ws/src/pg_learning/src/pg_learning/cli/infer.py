"""`pushgrasp infer`: draw the Q maps and the decision a policy would take on a scene (nothing is executed), or with
--steps N a rollout: one PNG per decision (OUT_01.png ...) and the scene after the last action (OUT_after.png)."""

from __future__ import annotations

import argparse
import textwrap
from pathlib import Path

import numpy as np

from pg_core.seeds import MIN_EVAL_SEED
from pg_policy.policies import options


def add_parser(sub: argparse._SubParsersAction) -> None:
    from pg_learning.cli.eval import add_sensor_argument

    p = sub.add_parser("infer", help="render a policy's Q maps and decision over a scene to PNG (no action)")
    p.add_argument("--policy", "--model", dest="model", default="lite",
                   help="shipped model folder name, model directory (grasp.pt + push.pt), a grasp .pt file, or a "
                        "registered policy or plugin (heuristic, ...; `pushgrasp policies`) (default: lite, the "
                        "shipped model)")
    p.add_argument("--scene", required=True, help="scene name (see `pushgrasp scene list`), YAML file, or random-N")
    p.add_argument("--seed", type=int, default=MIN_EVAL_SEED,
                   help=f"seed for generated scenes (random-N, novel-N, ...) and the policy (default {MIN_EVAL_SEED}, "
                        "the first evaluation seed)")
    p.add_argument("--trial", action="store_true",
                   help="the scene of `pushgrasp eval`'s trial SEED: a fixed scene (packed/caseNN, household/caseNN, "
                        "YAML) moved by the protocol's jitter drawn from the seed (1 cm, 11.25 deg), so a trial of "
                        "the records can be replayed and drawn; without it a fixed scene is the exact file")
    p.add_argument("--target", default=None, help="target colour (default: the scene's)")
    p.add_argument("--out", type=Path, required=True, help="output PNG (with --steps: the stem of the PNG sequence)")
    p.add_argument("--steps", type=int, default=0,
                   help="execute up to N decisions in the simulator under `pushgrasp eval`'s episode protocol (the "
                        "search for a hidden target; stops once the target is grasped or the episode ends, e.g. "
                        "target_lost), one PNG each plus the scene after; default 0: draw the first decision, "
                        "execute nothing")
    add_sensor_argument(p)
    options.add_arguments(p)  # the declared policy options; the grasp panel shows Q_g after the filter rules
    p.set_defaults(run=_run)


def draw(out: Path, obs, decision, q: dict[str, np.ndarray], title: str, grasp_filter: object = None) -> Path:
    """Colour heightmap with target outline and the decision arrow | max-over-rotations Q_g | Q_p (masked views).
    decision None: no arrow; q may be empty (the heightmap panel alone); grasp_filter: named in the Q_g panel's
    title when given and not "none"."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from pg_core.target_mask import target_mask

    hm = obs.heightmap
    mask = target_mask(hm.color, hm.valid, obs.target)
    first = "colour heightmap" + (" + decision" if decision is not None else "")
    after = f" after {grasp_filter}" if grasp_filter else ""
    panels = [(first, None)] + [(f"{k} Q{after if k == 'grasp' else ''} (max over rotations)", v)
                                for k, v in q.items()]
    fig, axes = plt.subplots(1, len(panels), figsize=(5 * len(panels), 5), dpi=100, squeeze=False)
    for ax, (name, maps) in zip(axes[0], panels, strict=True):
        if maps is None:
            ax.imshow(hm.color, origin="lower")
        else:
            ax.imshow(hm.color, origin="lower", alpha=0.35)  # under the cells without Q (q_window: -inf)
            im = ax.imshow(np.ma.masked_invalid(maps.max(axis=0)), origin="lower", cmap="jet")
            fig.colorbar(im, ax=ax, fraction=0.046)
        if mask.any():
            ax.contour(mask.astype(float), levels=[0.5], colors="white", linewidths=1.5)
        if decision is None:
            ax.set_title(name)
            continue
        dx, dy = np.cos(decision.yaw) * 12, np.sin(decision.yaw) * 12  # cols = x, rows = y
        color = "red" if decision.primitive == "grasp" else "cyan"
        ax.annotate("", xy=(decision.col + dx, decision.row + dy), xytext=(decision.col - dx, decision.row - dy),
                    arrowprops={"arrowstyle": "<->" if decision.primitive == "grasp" else "->", "color": color,
                                "lw": 2})
        ax.plot(decision.col, decision.row, "o", color=color, ms=5)
        ax.set_title(name)
        ax.set_xlabel("col (x)")
        ax.set_ylabel("row (y)")
    fig.suptitle(textwrap.fill(title, 50 * len(panels)))
    fig.tight_layout()
    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out)
    plt.close(fig)
    return out


def _title(scene: str, obs, d) -> str:
    return (f"{scene} target {obs.target}: {d.primitive} at ({d.x:.3f}, {d.y:.3f}, {d.z:.3f}) m, "
            f"yaw {np.degrees(d.yaw):.1f} deg, q {d.q:.3f} (masked max Q_g {d.grasp_q:.3f})")


def _run(args: argparse.Namespace) -> int:
    from pg_learning.environment.sim_env import SimEnv
    from pg_policy.decision.rules.pipeline import RulePipeline
    from pg_policy.policies.policy import PolicyOptions
    from pg_policy.policies.registry import make_policy

    if args.steps < 0:
        raise ValueError("--steps must be >= 0")
    policy = make_policy(args.model, PolicyOptions(seed=args.seed, overrides=options.from_args(args)))
    rules = getattr(policy, "rules", None)  # learned policies: the filter rules are named in the Q_g panel
    grasp_filter = (", ".join(r.spec() for r in rules.rules if r.kind == "filter")
                    if isinstance(rules, RulePipeline) else None)
    scene = args.scene
    if args.trial:
        from pg_learning.evaluation.runner import DEFAULT_JITTER_XY, DEFAULT_JITTER_YAW, trial_scene

        scene = trial_scene(args.scene, args.seed, DEFAULT_JITTER_XY, DEFAULT_JITTER_YAW)
    with SimEnv(sensor=args.sensor) as env:  # ValueError naming the profiles for an unknown one
        obs = env.reset(scene, seed=args.seed)
        if args.target:
            obs = type(obs)(obs.heightmap, args.target, obs.truth_target, obs.sim_time)
        policy.reset(args.seed)
        if args.steps == 0:
            d = policy.act(obs)
            print(_title(args.scene, obs, d))
            out = draw(args.out, obs, d, policy.q_maps(), _title(args.scene, obs, d), grasp_filter)
            print(f"wrote {out}")
            return 0
        return _rollout(args, env, policy, obs, grasp_filter)


def _rollout(args: argparse.Namespace, env, policy, obs, grasp_filter: object = None) -> int:
    """Decide, draw, execute, up to args.steps times, under the episode protocol of `pushgrasp eval` (the target
    memory the policy searches a hidden target with, refused futile pushes, the terminations: a trial's decisions
    are the evaluation's); exit status 0 once the target is grasped, else 1."""
    from pg_learning.evaluation.runner import observed, refused_step
    from pg_policy.perception.target_memory import search_limit
    from pg_policy.target_loop.episode import Episode, Limits, Outcome

    stem = args.out.with_suffix("")
    stem.parent.mkdir(parents=True, exist_ok=True)
    ep = Episode(Limits(), search_limit=search_limit(False))
    obs = observed(ep, env, obs)
    for k in range(1, args.steps + 1):
        d = policy.act(obs)
        title = f"step {k}: " + _title(args.scene, obs, d)
        draw(Path(f"{stem}_{k:02d}.png"), obs, d, policy.q_maps(), title, grasp_filter)
        veto = ep.vet(d)
        res = refused_step(d.primitive, veto) if veto is not None else env.step(d.primitive, d.x, d.y, d.z, d.yaw)
        ep.record(d, Outcome(refused=bool(res.refused), target_grasped=bool(res.target_grasped),
                             message=str(res.message)))
        print(f"{title} -> {res.message}{' (target grasped)' if res.target_grasped else ''}")
        nxt = env.observe()
        obs = observed(ep, env, type(nxt)(nxt.heightmap, args.target, nxt.truth_target, nxt.sim_time)
                       if args.target else nxt)
        if ep.over():
            if not ep.completed:
                print(f"episode over: {ep.termination}: {ep.why}")
            break
    verdict = ("target grasped" if res.target_grasped
               else f"{ep.termination}" if ep.termination else "target not grasped")
    after = draw(Path(f"{stem}_after.png"), obs, None, {}, f"after {k} action(s): {verdict}")
    print(f"wrote {stem}_01.png .. {stem}_{k:02d}.png and {after}")
    return 0 if res.target_grasped else 1
