"""Throw probe: how far a grasp that misses the middle of a household object moves it (no ROS, no policy).

Each object lies alone on the table at rest (as in pg_sim.world.grasp_probe). A grasp goes to a point off the
object's centre, perpendicular to a seeded one of the 16 closing directions, at ``--offsets`` fractions of the
object's half-width, with the fingertip z of the policy's jaw-line rule (``pg_core.action_geometry.grasp_z_at``).
For each grasp the probe records whether the object was lifted, how far a failed grasp moved it on the table (m)
and the fastest horizontal speed any object reached during the grasp (m/s). A finger that lands on an object and
presses it into the table (the arm drives to the planned depth) squeezes it out sideways; that is what throws
round and lying objects out of the workspace in evaluation (docs/RESULTS.md, "Rubber finger pads").

    python -m pg_sim.world.throw_probe                          # fruit can bottle mug, 3 objects, 2 offsets
    python -m pg_sim.world.throw_probe bottle can --guard 10    # with a 10 N guarded descent
    pushgrasp scene throw-probe --objects 5                     # the same through the CLI
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np

from pg_core import heightmap as hm
from pg_core.action_geometry import grasp_z_at
from pg_core.geometry import Geometry, load
from pg_core.palette import COLORS
from pg_sim.world.sim_mode import DEFAULT_SIM_MODE, SIM_MODES

CATEGORIES = ("fruit", "can", "bottle", "mug")  # defaults: the round objects thrown in evaluation
OFFSETS = (0.4, 0.7)  # fractions of the object's half-width off its centre
TRIES = 4  # grasps per object and offset (each from the object's rest pose, a seeded rotation)
THROWN_M = 0.05  # a failed grasp that moves the object farther than this (m) threw it
FAST_MPS = 0.5  # horizontal speed (m/s) no object reaches from a 0.1 m/s push or a 0.3 m/s lift unless thrown


@dataclass(frozen=True)
class Throw:
    category: str
    object_id: str
    offset: float        # fraction of the half-width off centre
    rotation: int        # closing direction, of 16
    lifted: bool         # the object was held after the lift
    moved: float         # m on the table after a failed grasp (0 when lifted)
    peak_speed: float    # m/s, fastest horizontal speed of any object during the grasp


def run(categories: Sequence[str], objects: int = 3, first: int = 0, offsets: Sequence[float] = OFFSETS,
        seed: int = 0, sim_mode: str = DEFAULT_SIM_MODE, geometry: Geometry | None = None) -> list[Throw]:
    """Every grasp of the probe (module docstring). Raises ValueError for an unknown category (from the catalog)."""
    import pybullet as p

    from pg_sim.objects.catalog import household_info
    from pg_sim.world.grasp_probe import build_scene
    from pg_sim.world.primitives import PrimitiveExecutor
    from pg_sim.world.world import World

    class _Timed(World):
        """The world, recording the fastest horizontal object speed since `peak` was last reset."""

        peak = 0.0

        def step(self) -> float:
            t = super().step()
            for body in self.objects:
                vx, vy, _ = p.getBaseVelocity(body, physicsClientId=self.client)[0]
                self.peak = max(self.peak, math.hypot(vx, vy))
            return t

    rng = np.random.default_rng(seed)
    out: list[Throw] = []
    with _Timed(geometry, mode=sim_mode) as world:
        executor = PrimitiveExecutor(world)
        prims, rotations = world.geometry.primitives, world.geometry.heightmap.rotations
        for category in categories:
            for k in range(objects):
                object_id = f"{category}/{first + k}"
                half = 0.5 * min(household_info(object_id).extents[:2])
                for _ in range(TRIES):
                    rest = build_scene(world, category, object_id, COLORS["green"], rng)
                    for frac in offsets:
                        world.load_scene(rest)
                        body = world.target_id
                        start = np.asarray(world.object_poses()[body][:2], dtype=np.float64)
                        obs = world.observe().heightmap
                        rotation = int(rng.integers(rotations))
                        yaw = hm.rotation_yaw(rotation, rotations)
                        x, y = start + frac * half * np.array([-math.sin(yaw), math.cos(yaw)])
                        row, col = hm.world_to_pixel(x, y, obs.bounds, obs.resolution)
                        z = grasp_z_at(obs, row, col, prims, yaw=yaw)
                        world.peak = 0.0
                        res = executor.grasp(float(x), float(y), float(z), yaw)
                        moved = 0.0 if res.target_grasped else float(
                            np.linalg.norm(np.asarray(world.object_poses()[body][:2]) - start))
                        out.append(Throw(category, object_id, frac, rotation, bool(res.target_grasped), moved,
                                         float(world.peak)))
    return out


def table(throws: Sequence[Throw]) -> str:
    """One row per category and offset, then all: grasps, lifted, failed grasps that threw the object (moved more
    than THROWN_M), failed grasps with an object faster than FAST_MPS, and the farthest throw."""
    head = f"{'category':10s} {'offset':>6s} {'grasps':>6s} {'lifted':>7s} {'thrown':>7s} {'fast':>5s} {'max m':>6s}"
    lines = [head, "-" * len(head)]

    def row(name: str, offset: str, ts: Sequence[Throw]) -> str:
        failed = [t for t in ts if not t.lifted]
        thrown = sum(t.moved > THROWN_M for t in failed)
        fast = sum(t.peak_speed > FAST_MPS for t in failed)
        far = max((t.moved for t in failed), default=0.0)
        return (f"{name:10s} {offset:>6s} {len(ts):6d} {sum(t.lifted for t in ts):7d} {thrown:7d} {fast:5d} "
                f"{far:6.2f}")

    for cat in dict.fromkeys(t.category for t in throws):
        for off in sorted({t.offset for t in throws}):
            lines.append(row(cat, f"{off:.2f}", [t for t in throws if t.category == cat and t.offset == off]))
    lines += ["-" * len(head), row("all", "", throws)]
    return "\n".join(lines)


def add_arguments(ap: argparse.ArgumentParser) -> None:
    ap.add_argument("categories", nargs="*", default=list(CATEGORIES),
                    help=f"household categories to probe (default: {' '.join(CATEGORIES)})")
    ap.add_argument("--objects", type=int, default=3, help="objects per category (default 3)")
    ap.add_argument("--first", type=int, default=0, help="index of the first object id (default 0: training objects)")
    ap.add_argument("--offsets", type=float, nargs="+", default=list(OFFSETS),
                    help="grasp points off centre, fractions of the object's half-width (default 0.4 0.7)")
    ap.add_argument("--guard", type=float, default=None, metavar="N",
                    help="override primitives.grasp_stop_force (N): the descent stops where the objects press up "
                         "on the fingers with more (default: the config's)")
    ap.add_argument("--seed", type=int, default=0, help="seed of the object yaws and closing directions (default 0)")
    ap.add_argument("--sim-mode", choices=list(SIM_MODES), default=DEFAULT_SIM_MODE,
                    help=f"simulation mode (default {DEFAULT_SIM_MODE}, as evaluation)")


def execute(args: argparse.Namespace) -> int:
    if args.objects < 1 or any(not 0.0 <= f < 1.0 for f in args.offsets):
        raise ValueError(f"--objects must be >= 1 and --offsets in [0, 1), got {args.objects}, {args.offsets}")
    if args.guard is not None and args.guard < 0:
        raise ValueError(f"--guard must be >= 0 N, got {args.guard}")
    geometry = load()
    if args.guard is not None:
        geometry = replace(geometry, primitives=replace(geometry.primitives, grasp_stop_force=args.guard))
    t0 = time.perf_counter()
    throws = run(args.categories, args.objects, args.first, args.offsets, args.seed, args.sim_mode, geometry)
    print(table(throws))
    print(f"{len(throws)} grasps, {time.perf_counter() - t0:.0f} s wall time ({args.sim_mode} mode, guard "
          f"{geometry.primitives.grasp_stop_force:g} N, pads {geometry.gripper.pad_friction:g})")
    return 0


def main(argv: Sequence[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m pg_sim.world.throw_probe",
                                 description=(__doc__ or "").splitlines()[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    add_arguments(ap)
    return execute(ap.parse_args(argv))


if __name__ == "__main__":
    sys.exit(main())
