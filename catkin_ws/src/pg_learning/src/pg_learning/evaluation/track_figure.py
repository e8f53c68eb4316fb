"""A picture of a tracked target: one evaluation trial with the target named by a point (or a mask), a panel per
observation showing the colour heightmap, the mask the loop tracked (green outline), the simulator's ground truth
of the target (red outline, never shown to the policy) and the action decided on it (arrow: a push from its start
along its direction; cross: a grasp).

    python -m pg_learning.evaluation.track_figure --scenes random-15 --seed 1000003 --colours same \
        --target-by point --out docs/img/tracking/random15_same.png

The trial runs through pg_learning.evaluation.runner.run_trial exactly as `pushgrasp eval --target-by` runs it; this
module only watches (it wraps the environment's observations and the policy's `act`). Frames: the panels show the
heightmap grid (columns along x, rows along y, pg_core.heightmap), y up.
"""

from __future__ import annotations

import argparse
import math
import textwrap
from dataclasses import dataclass
from typing import Any

import numpy as np

from pg_learning.evaluation.target_by import MASK, POINT, iou

MAX_PANELS = 8  # observations drawn (the first ones)


@dataclass
class Frame:
    """One observation: colour heightmap (H, W, 3) uint8, tracked and true target masks (H, W) bool, the decision
    (primitive, row, col, yaw rad) and the policy's note."""

    color: np.ndarray
    tracked: np.ndarray
    truth: np.ndarray
    decision: tuple[str, int, int, float]
    note: str


class Watcher:
    """Wraps an environment and a policy so that every observation the policy acts on is kept as a Frame."""

    def __init__(self, env: Any, policy: Any) -> None:
        self.env, self.policy, self.frames = env, policy, []
        self.truth: np.ndarray | None = None
        self._reset, self._observe, self._act = env.reset, env.observe, policy.act
        env.reset, env.observe, policy.act = self.reset, self.observe, self.act

    def reset(self, *args: Any, **kwargs: Any) -> Any:
        obs = self._reset(*args, **kwargs)
        self.truth = np.asarray(obs.truth_target, dtype=bool)
        return obs

    def observe(self) -> Any:
        obs = self._observe()
        self.truth = np.asarray(obs.truth_target, dtype=bool)
        return obs

    def act(self, obs: Any) -> Any:
        d = self._act(obs)
        tracked = np.zeros_like(self.truth) if obs.mask is None else np.asarray(obs.mask, dtype=bool)
        self.frames.append(Frame(obs.heightmap.color.copy(), tracked, self.truth.copy(),
                                 (d.primitive, int(d.row), int(d.col), float(d.yaw)),
                                 str(getattr(self.policy, "last_note", ""))))
        return d


def draw(frames: list[Frame], title: str, out: str, resolution: float, push_length: float) -> None:
    """Write the panels of `frames` (at most MAX_PANELS) to the PNG `out`."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    frames = frames[:MAX_PANELS]
    fig, axes = plt.subplots(1, len(frames), figsize=(3.0 * len(frames), 3.6), squeeze=False)
    for k, (ax, f) in enumerate(zip(axes[0], frames, strict=True)):
        ax.imshow(f.color, origin="lower")
        if f.truth.any():
            ax.contour(f.truth, levels=[0.5], colors="red", linewidths=1.0)
        if f.tracked.any():
            ax.contour(f.tracked, levels=[0.5], colors="lime", linewidths=1.2, linestyles="--")
        prim, row, col, yaw = f.decision
        if prim == "push":
            n = push_length / resolution
            ax.annotate("", xy=(col + n * math.cos(yaw), row + n * math.sin(yaw)), xytext=(col, row),
                        arrowprops={"arrowstyle": "->", "color": "white", "lw": 1.5})
        else:
            ax.plot([col], [row], marker="x", color="white", markersize=9, mew=2)
        score = iou(f.tracked, f.truth)
        ax.set_title(f"step {k}: {prim}, IoU {'-' if score is None else f'{score:.2f}'}", fontsize=9)
        ax.set_xticks([])
        ax.set_yticks([])
    fig.suptitle(textwrap.fill(title, width=int(40 * len(frames))), fontsize=10)  # about 40 characters a panel
    fig.tight_layout()
    fig.savefig(out, dpi=80)
    plt.close(fig)


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description="PNG sequence of a tracked target in one evaluation trial")
    ap.add_argument("--policy", default="lite", help="policy name or model directory (default lite)")
    ap.add_argument("--scenes", default="random-15", help="one scene or generated family (default random-15)")
    ap.add_argument("--seed", type=int, default=1_000_000, help="evaluation seed (>= 1,000,000)")
    ap.add_argument("--allow-train-seeds", action="store_true",
                    help="accept a seed below 1,000,000 (a training scene: for looking into tuning runs)")
    ap.add_argument("--target-by", choices=(POINT, MASK), default=POINT, help="how the target is named")
    ap.add_argument("--colours", default="same", help="scene colours: unique, repeated or same (default same)")
    ap.add_argument("--max-actions", type=int, default=MAX_PANELS, help="action budget of the trial")
    ap.add_argument("--out", required=True, help="PNG to write")
    args = ap.parse_args(argv)

    from pg_learning.environment.sim_env import SimEnv
    from pg_learning.evaluation.runner import DEFAULT_JITTER_XY, DEFAULT_JITTER_YAW, run_trial, trial_scene
    from pg_policy.policies.registry import make_policy
    from pg_policy.target_loop.episode import Limits, check_eval_seed

    if not args.allow_train_seeds:
        check_eval_seed(args.seed)
    with SimEnv(colours=args.colours) as env:
        watcher = Watcher(env, make_policy(args.policy))
        scene = trial_scene(args.scenes, args.seed, DEFAULT_JITTER_XY, DEFAULT_JITTER_YAW)  # as `pushgrasp eval`
        rec = run_trial(env, watcher.policy, scene, args.seed, Limits(max_actions=args.max_actions),
                        scene_name=args.scenes, target_by=args.target_by)
        geo = env.geometry
    title = (f"{args.scenes} seed {args.seed}, colours {args.colours}, target by {args.target_by}: "
             f"{rec.termination} (green dashed: tracked, red: truth)")
    draw(watcher.frames, title, args.out, geo.heightmap.resolution, geo.primitives.push_length)
    print(f"{rec.termination}: {rec.message}; {len(watcher.frames)} observations -> {args.out}")


if __name__ == "__main__":
    main()
