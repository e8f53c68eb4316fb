"""Re-run one protocol trial of the shipped `lite` model and print, per action, the decision, its outcome, the push's
landing cover (pg_policy.push_landing) and the target's pose afterwards (simulator ground truth).

The trial is the eval's (pg_policy.evaluate.run_trial with the same scene jitter and seed), so its decisions match
the `results.json` record of the same code and machine. Used to find why the failed trials of docs/RESULTS.md failed.

Run (after `source scripts/ros_env.sh`; about 30 s per trial):
  .venv/bin/python results/experiments/push_guards/trace_trial.py packed/case09 1000077 --edge-guard off \
      --push-landing off [--png /tmp/c9_77]
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path

import numpy as np


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("scene", help="scene name (packed/case09, random-10, ...)")
    ap.add_argument("seed", type=int, help="trial seed (the protocol's: 1000000 + i)")
    ap.add_argument("--grasp-check", default=None, help="grasp check (default: the model's)")
    ap.add_argument("--edge-guard", default=None, choices=("on", "off"), help="default: the model's")
    ap.add_argument("--push-landing", default=None, choices=("on", "off"), help="default: the model's")
    ap.add_argument("--png", type=Path, default=None, help="stem of one `pushgrasp infer`-style PNG per decision")
    args = ap.parse_args()

    import pybullet as p

    from pg_policy.evaluate import DEFAULT_JITTER_XY, DEFAULT_JITTER_YAW, run_trial, trial_scene
    from pg_policy.heightmap import world_to_pixel
    from pg_policy.infer_cli import draw
    from pg_policy.policies import PolicyOptions, make_policy
    from pg_policy.push_landing import LandingGuard
    from pg_policy.sim_env import SimEnv

    def flag(v: str | None) -> bool | None:
        return None if v is None else v == "on"

    policy = make_policy("lite", PolicyOptions(grasp_check=args.grasp_check, edge_guard=flag(args.edge_guard),
                                               push_landing=flag(args.push_landing)))
    landing = LandingGuard(policy.geometry)
    rotations = policy.geometry.heightmap.rotations

    class TracedEnv(SimEnv):
        index = 0
        obs = None

        def pose(self) -> str:
            tid = self.world.target_id
            if tid is None:
                return "target removed (grasped)"
            pos, orn = p.getBasePositionAndOrientation(tid, physicsClientId=self.world.client)
            rpy = np.degrees(p.getEulerFromQuaternion(orn))
            return f"target at ({pos[0]:+.3f}, {pos[1]:+.3f}, {pos[2]:.3f}) m, rpy ({rpy[0]:+.0f}, {rpy[1]:+.0f}, " \
                   f"{rpy[2]:+.0f}) deg"

        def reset(self, scene, seed=0):
            self.obs = super().reset(scene, seed)
            print(f"start: {self.pose()}")
            return self.obs

        def observe(self):
            self.obs = super().observe()
            return self.obs

        def step(self, primitive, x, y, z, yaw):
            if args.png is not None:
                draw(args.png.with_name(f"{args.png.name}_{self.index:02d}.png"), self.obs, policy.last,
                     policy.q_maps(), f"{args.scene} seed {args.seed} #{self.index}")
            cover = ""
            if primitive == "push":
                hm = self.obs.heightmap
                row, col = world_to_pixel(x, y, hm.bounds, hm.resolution)
                r = int(round(yaw / (2 * math.pi / rotations))) % rotations
                cover = f", landing cover {landing.cover(hm.height, r, row, col):.2f}"
            res = super().step(primitive, x, y, z, yaw)
            print(f"#{self.index} {primitive} at ({x:+.3f}, {y:+.3f}, {z:.3f}) m, yaw {math.degrees(yaw):.0f} deg"
                  f"{cover}: {res.message} {res.grasped_color or ''} | {self.pose()} | {policy.last_note}")
            self.index += 1
            return res

    scene = trial_scene(args.scene, args.seed, DEFAULT_JITTER_XY, DEFAULT_JITTER_YAW)
    env = TracedEnv()
    try:
        record = run_trial(env, policy, scene, args.seed, scene_name=args.scene)
    finally:
        env.close()
    print(f"{args.scene} seed {args.seed}: {record.termination}")


if __name__ == "__main__":
    main()
