"""Headless simulation demo without ROS: settle a scene, grasp the target with a scripted ground-truth grasp.

This is the foundation-level demo (no learned policy yet): the grasp pose comes from the simulator's ground truth
(target centre, fingers closing along the target's x axis), retried up to --attempts times.
Prints the outcome and writes before/after PNGs. Exit code 0 only when the target was grasped.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

from pg_core import heightmap as hm
from pg_core.action_geometry import grasp_z_at
from pg_sim.world.primitives import PrimitiveExecutor, PrimitiveRefused
from pg_sim.world.render import render_scene_png
from pg_sim.world.scene_source import make_world_with_scene


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scene", default="household/case11", help="scene name, YAML file or random-N")
    ap.add_argument("--seed", type=int, default=0, help="seed for random-N scenes")
    ap.add_argument("--out", type=Path, default=Path("demo_out"), help="folder for before/after PNGs")
    ap.add_argument("--attempts", type=int, default=3, help="grasp attempts before giving up")
    args = ap.parse_args(argv)

    wall = time.perf_counter()
    with make_world_with_scene(args.scene, args.seed) as world:
        before = render_scene_png(world, args.out / "before.png", f"{args.scene}: before")
        ex = PrimitiveExecutor(world)
        t0, grasped = world.sim_time, False
        for attempt in range(1, args.attempts + 1):
            x, y, _, _, _, yaw = world.object_poses()[world.target_id]
            obs = world.observe()
            r, c = hm.world_to_pixel(x, y, obs.heightmap.bounds, obs.heightmap.resolution)
            rotations = world.geometry.heightmap.rotations
            rot = round((yaw % np.pi) / hm.rotation_step(rotations)) % rotations  # closing along the object's x axis
            yaw = hm.rotation_yaw(rot, rotations)
            try:
                res = ex.grasp(float(x), float(y), grasp_z_at(obs.heightmap, r, c, world.geometry.primitives, yaw=yaw),
                               yaw)
            except PrimitiveRefused as exc:
                print(f"attempt {attempt}: refused: {exc}")
                continue
            print(f"attempt {attempt}: {res.arm} arm, {res.message}, target grasped: {res.target_grasped}")
            if res.target_grasped:
                grasped = True
                break
        after = render_scene_png(world, args.out / "after.png", f"{args.scene}: after")
        sim_s = world.sim_time - t0
    print(f"scripted ground-truth grasp demo (no learned policy yet): success={grasped} grasps={attempt} pushes=0 "
          f"sim_time={sim_s:.1f}s wall_time={time.perf_counter() - wall:.1f}s")
    print(f"wrote {before} and {after}")
    return 0 if grasped else 1


if __name__ == "__main__":
    sys.exit(main())
