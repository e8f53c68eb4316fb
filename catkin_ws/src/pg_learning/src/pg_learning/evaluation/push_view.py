"""What the overhead camera sees of a pushed object while the push goes on: can a tracker watch the push?

A tracker that knew where each push carried the target would follow it past look-alikes (docs/RESULTS.md, "A
mask that names one of two look-alikes": `track_replay --known-shift`). The camera streams while the arm moves, so
the question is how much of the target it sees during the stroke. This tool pushes the target of generated or
shipped scenes from `behind_m` behind its centre straight through it (the direction drawn from the seed and the
scene's name), watches the camera every `every_m` metres of the stroke with the robot's own pixels removed
(pg_sim.world.world.World.robot_pixels: a self-filter), and counts the target's cells in view (the simulator's
labels) against its cells before the push.

    python -m pg_learning.evaluation.push_view --scenes packed/case01 random-15 --seeds 4 --out OUT

prints one line per push (the target's visible cells per frame) and a summary (median share in view, share of
frames that see half of it or more, and none of it), and writes OUT/push_view.json and OUT/push_view.png (the
heightmaps of the first push, robot cells black, the target outlined). Seeds are the training seeds (5,000 on)
unless --seed says otherwise. Frames and units: `world` metres and radians; heightmaps as pg_core.heightmap.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import zlib
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from pg_core.heightmap import Heightmap, cell_centres

BEHIND_M = 0.06  # the fingers come down this far behind the target's centre (m), then push through it
EVERY_M = 0.02  # a frame every this many metres of the stroke
PUSH_Z_M = 0.02  # the fingertips' height during the stroke (m)
FIRST_SEED = 5_000  # the first seed by default: a training seed, as in the training-seed evaluations


@dataclass
class WatchedPush:
    """One push: the scene and seed, its direction (rad), the target's cells before it, and per frame the target's
    cells in view with the robot removed; `views` holds the frames' heightmaps (not saved)."""

    scene: str
    seed: int
    yaw: float
    cells_before: int
    visible: list[int] = field(default_factory=list)
    views: list[tuple[Heightmap, np.ndarray]] = field(default_factory=list, repr=False)

    def shares(self) -> list[float]:
        """The target's share in view per frame (visible cells over its cells before the push)."""
        return [v / self.cells_before for v in self.visible]


def watch_push(scene: str, seed: int, behind_m: float = BEHIND_M, every_m: float = EVERY_M) -> WatchedPush:
    """Push the target of `scene` (seed `seed`) through its centre from `behind_m` behind it, in a direction drawn
    from the seed and the scene's name, watching every `every_m` m of the stroke. ValueError when the first view
    shows no target."""
    from pg_learning.environment.sim_env import SimEnv  # the simulator, loaded only when pushes are watched

    with SimEnv() as env:
        obs = env.reset(scene, seed)
        world, truth = env.world, obs.truth_target
        if not truth.any():
            raise ValueError(f"{scene} seed {seed}: the target is not in view before the push")
        hm0 = obs.heightmap
        centre = cell_centres(*np.nonzero(truth), hm0.bounds, hm0.resolution).mean(axis=0)
        yaw = float(np.random.default_rng([seed, zlib.crc32(scene.encode())]).uniform(0.0, 2 * math.pi))
        start = centre - behind_m * np.array([math.cos(yaw), math.sin(yaw)])
        out = WatchedPush(scene, seed, yaw, int(truth.sum()))
        every = max(1, round(every_m / (world.geometry.primitives.push_speed * world.time_step)))
        ticks = [0]

        def watch() -> None:
            ticks[0] += 1
            if ticks[0] % every:
                return
            obs = world.observe(hide_robot=True)  # the returned frame has no depth on the robot
            labels = world.label_heightmap(obs.frame)
            seen = labels == world.target_id
            out.visible.append(int(seen.sum()))
            out.views.append((obs.heightmap, seen))

        env.executor.stroke_watch = watch
        env.executor.push(float(start[0]), float(start[1]), PUSH_Z_M, yaw)
    return out


def summary(pushes: list[WatchedPush]) -> dict[str, Any]:
    """Median share of the target in view over all frames, and the shares of frames with half of it or more in
    view and with none (under 5 %)."""
    shares = np.array([s for p in pushes for s in p.shares()])
    if shares.size == 0:
        return {"frames": 0}
    return {"pushes": len(pushes), "frames": int(shares.size), "median_share": round(float(np.median(shares)), 3),
            "half_or_more": round(float(np.mean(shares >= 0.5)), 3), "none": round(float(np.mean(shares < 0.05)), 3)}


def draw(push: WatchedPush, path: str) -> None:
    """PNG of one watched push: each frame's colour heightmap, cells without data (the robot) black, the target's
    visible cells outlined."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    n = len(push.views)
    fig, axes = plt.subplots(1, n, figsize=(2.6 * n, 3.0), squeeze=False)
    for i, (hm, seen) in enumerate(push.views):
        ax = axes[0, i]
        ax.imshow(np.where(hm.valid[..., None], hm.color, 0), origin="lower")
        if seen.any():
            ax.contour(seen, levels=[0.5], colors="red", linewidths=1.0)
        ax.set_title(f"{i + 1}: {push.visible[i]} of {push.cells_before}", fontsize=9)
        ax.set_xticks([])
        ax.set_yticks([])
    fig.suptitle(f"{push.scene} seed {push.seed}: target cells in view while the push goes on", fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=80)
    plt.close(fig)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m pg_learning.evaluation.push_view", description=__doc__.split("\n")[0])
    ap.add_argument("--scenes", nargs="+", required=True, help="scenes or generated families (as pushgrasp eval)")
    ap.add_argument("--seeds", type=int, default=4, help="pushes per scene, seeds --seed, --seed + 1, ...")
    ap.add_argument("--seed", type=int, default=FIRST_SEED, help="first seed (default: 5000, a training seed)")
    ap.add_argument("--behind", type=float, default=BEHIND_M, help="m behind the target's centre the push starts")
    ap.add_argument("--every", type=float, default=EVERY_M, help="m of the stroke between two frames")
    ap.add_argument("--out", required=True, help="folder for push_view.json and push_view.png")
    args = ap.parse_args(argv)
    if args.seeds < 1 or args.behind <= 0 or args.every <= 0:
        ap.error("--seeds must be >= 1 and --behind, --every > 0")
    os.makedirs(args.out, exist_ok=True)
    pushes = []
    for seed in range(args.seed, args.seed + args.seeds):
        for scene in args.scenes:
            push = watch_push(scene, seed, args.behind, args.every)
            print(f"{scene} seed {seed} yaw {math.degrees(push.yaw):.0f} deg: target {push.cells_before} cells "
                  f"before, in view per frame {push.visible}", flush=True)
            pushes.append(push)
    result = summary(pushes)
    print(json.dumps(result))
    with open(os.path.join(args.out, "push_view.json"), "w") as f:
        json.dump({"summary": result, "pushes": [{k: v for k, v in vars(p).items() if k != "views"}
                                                 for p in pushes]}, f, indent=1)
    draw(pushes[0], os.path.join(args.out, "push_view.png"))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
