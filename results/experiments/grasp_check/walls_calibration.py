"""Lone-object grasps in the simulator: does the `jaw-walls` wall test predict which grasps hold?

Each random-scene block (pg_sim.random_scene.BLOCKS) is dropped alone at the workspace centre in `--orientations`
random orientations (seeded), and grasped through the pad-centred line of its visible cells at 8 closing axes
(yaw = r * 22.5 deg), fingertips at pg_policy.action_geometry.grasp_z, as the learned policy's grasp would be.
For each grasp that fits the open jaw (the footprint part of the jaw test) the wall height of
pg_policy.grasp_check.JawGraspCheck.wall_height is recorded with two windows, and the table at the end counts, per
shape and setting, the grasps the test passes and refuses and how many of each held.

Run (after `source scripts/ros_env.sh`; about 5 min on 2 cores):
  .venv/bin/python results/experiments/grasp_check/walls_calibration.py --out walls_calibration.jsonl
"""

from __future__ import annotations

import argparse
import json
import math
from collections import defaultdict

import numpy as np

WINDOWS = (0.002, 0.004)  # m: wall windows compared
TOLS = (0.0, 0.002, 0.004)  # m: wall tolerances compared


def grasps(orientations: int, seed: int):
    """Yield one record per grasp (dict: shape, orientation index k, rotation r, fit, and when fit: zg, walls, ok)."""
    from pg_policy.action_geometry import grasp_z
    from pg_policy.grasp_check import JawGraspCheck
    from pg_policy.heightmap import world_to_pixel
    from pg_sim.colors import resolve_color
    from pg_sim.primitives import PrimitiveExecutor
    from pg_sim.random_scene import BLOCKS
    from pg_sim.scene import ObjectSpec
    from pg_sim.world import World

    rng = np.random.default_rng(seed)
    with World() as world:
        checks = {w: JawGraspCheck(world.geometry, walls=True, wall_window_m=w) for w in WINDOWS}
        planner = checks[WINDOWS[0]].planner
        for shape in BLOCKS:
            for k in range(orientations):
                rpy = tuple(float(a) for a in rng.uniform(-np.pi, np.pi, 3))
                spec = ObjectSpec(shape=shape, size=None, color=resolve_color("green"), pose=(0.0, 0.0, 0.07, *rpy),
                                  mesh=None, target=True, name="target")
                for r in range(8):
                    world.clear_objects()
                    world.home()
                    world.add_object(spec)
                    world.settle()
                    hm = world.observe().heightmap
                    target = hm.height > 0.004
                    cells, _ = planner.around(hm, target)
                    t = target[cells.slice].reshape(-1)
                    t_xy, t_h = cells.xy[t], cells.h[t]
                    centre = t_xy.mean(axis=0)
                    row, col = world_to_pixel(float(centre[0]), float(centre[1]), hm.bounds, hm.resolution)
                    yaw = r * math.pi / 8
                    zg = grasp_z(hm.height, row, col, world.geometry.primitives)
                    fit = planner.grasp_fit(t_xy, np.zeros((0, 2)), np.zeros(0), centre, yaw, zg)
                    rec = {"shape": shape, "k": k, "r": r, "fit": fit is not None}
                    if fit is not None:
                        res = PrimitiveExecutor(world).grasp(float(fit[1][0]), float(fit[1][1]), zg, yaw)
                        rec.update(zg=zg, ok=bool(res.target_grasped),
                                   walls={str(w): c.wall_height(t_xy, t_h, fit[1], yaw) for w, c in checks.items()})
                    yield rec


def table(records: list[dict]) -> str:
    """Markdown: per shape and setting, grasps passed (held / dropped) and refused (held / dropped)."""
    fit = [r for r in records if r["fit"]]
    counts: dict[tuple, list[int]] = defaultdict(lambda: [0, 0, 0, 0])
    for r in fit:
        for w in WINDOWS:
            for tol in TOLS:
                passed = r["walls"][str(w)] >= r["zg"] + tol
                for shape in (r["shape"], "all"):
                    counts[(shape, w, tol)][(0 if passed else 2) + (0 if r["ok"] else 1)] += 1
    lines = ["| shape | window (mm) | tol (mm) | passed: held / dropped | refused: held / dropped |",
             "|---|---|---|---|---|"]
    for (shape, w, tol), c in sorted(counts.items(), key=lambda kv: (kv[0][0] != "all", kv[0])):
        lines.append(f"| {shape} | {w * 1000:.0f} | {tol * 1000:.0f} | {c[0]} / {c[1]} | {c[2]} / {c[3]} |")
    return "\n".join(lines)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--orientations", type=int, default=16, help="random orientations per shape (default 16)")
    ap.add_argument("--seed", type=int, default=11, help="seed of the orientations (default 11)")
    ap.add_argument("--out", required=True, help="JSON-lines file of the grasps")
    args = ap.parse_args()
    records = []
    with open(args.out, "w") as f:
        for i, rec in enumerate(grasps(args.orientations, args.seed)):
            records.append(rec)
            f.write(json.dumps(rec) + "\n")
            if i % 50 == 49:
                print(f"{i + 1} grasps", flush=True)
    print(table(records))


if __name__ == "__main__":
    main()
