"""Grasp-height probe: how often a grasp at the cells a policy could pick lifts a household object, per grasp-height
rule (no ROS, no policy).

Each object lies alone on the table at rest (``tilted-bowl``: a bowl resting tilted on a 45 mm block;
``upturned-bowl``: a bowl upside down; ``block``: the block shapes of the block scenes, as a control). The probe
renders the heightmap, takes the object's cells from the simulator's ground-truth label map and picks candidate
grasps there, as the policy's cells and rotations:

- vessels (bowl, plate, cup, mug, tilted-bowl): ``rim`` cells (within 4 mm of the object's outline), ``wall`` cells
  (10-16 mm inside it: the inner wall, or the floor near the wall) and ``deep`` cells (22-30 mm inside it: the floor
  of a small bowl, a cup or a plate's well, a big bowl's inner wall) at ``--angles`` directions around the object,
  closing across the wall (the rotation nearest the radial direction and the next one, 22.5 deg off; with
  ``--off-normal K,...`` the rotations K steps of 22.5 deg off the radial one instead, the regions named ``rim+K``,
  ``wall+K``, ``deep+K``); cups and mugs also their ``centre`` (the cell farthest from the outline) at two crossing
  rotations, and mugs their ``handle`` (the cells beyond the body's inscribed circle) closing across the handle and
  radially;
- long thin tools (knife, spoon, fork, spatula, scissors): the medial cell at five stations along the tool's long
  axis, closing across it (nearest rotation and the next); ``high`` where the cell is 5 mm or more above the table
  (handles, a spoon's bowl, the finger rings), ``low`` elsewhere (blades, tines, a spatula's head);
- an upturned bowl: its ``foot`` (the centroid of its cells within 4 mm of its top, and the cells 3 cells off it
  along x and y) at two crossing rotations;
- blocks: the centre at two crossing rotations.

Every candidate is executed with the fingertip z of each rule (the scene reloaded at its rest pose before each grasp;
a grasp whose z two rules agree on runs once): ``cell`` is :func:`pg_core.action_geometry.grasp_z` of the candidate
cell alone (DESIGN.md section 4 with the low-object rule: what every caller computed before the jaw-line rule),
``jaw-line`` the same function given the rotation's yaw and the colour heightmap (the contract: the policy's
``action_pose``). Success = the object is held after the lift (``PrimitiveResult.target_grasped``).

    python -m pg_sim.world.grasp_probe                      # every category, 4 objects each, both rules
    python -m pg_sim.world.grasp_probe bowl cup --objects 5 --by-region --out probe.json
    pushgrasp scene grasp-probe bowl tilted-bowl            # the same through the CLI
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass, replace
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from pg_core import heightmap as hm
from pg_core.action_geometry import grasp_z, grasp_z_at
from pg_core.geometry import Geometry, load
from pg_core.palette import COLORS
from pg_sim.world.sim_mode import DEFAULT_SIM_MODE, SIM_MODES

if TYPE_CHECKING:  # the simulator (pybullet, meshes) loads when a probe runs, not with the CLI's parsers
    from pg_sim.scenes.scene import SceneSpec
    from pg_sim.world.world import World

VESSELS = ("bowl", "plate", "cup", "mug", "tilted-bowl")
TOOLS = ("knife", "spoon", "fork", "spatula", "scissors")
CATEGORIES = (*VESSELS, "upturned-bowl", *TOOLS, "block")
BLOCKS = ("cube", "half_cube", "cylinder", "rect", "triangle", "half_cylinder")
COLOUR_NAMES = ("green", "blue", "yellow", "red", "gray", "purple")  # objects take these in turn
BANDS = {"rim": (0.0, 0.004), "wall": (0.010, 0.016), "deep": (0.022, 0.030)}  # m from a vessel's outline
STATIONS = (-0.4, -0.2, 0.0, 0.2, 0.4)  # along a tool's long axis, fractions of its length
HIGH_CELL_M = 0.005  # tool cells at least this high are `high` (handles), lower ones `low` (blades, tines)
TILT_SUPPORT = "cube"  # the block a tilted bowl rests on


def cell_rule(obs: hm.Heightmap, geometry: Geometry, rotation: int, row: int, col: int) -> float:
    """Fingertip z of the candidate cell alone (no jaw line)."""
    return grasp_z(obs.height, row, col, geometry.primitives, zmin=float(obs.bounds[2, 0]))


def jaw_line_rule(obs: hm.Heightmap, geometry: Geometry, rotation: int, row: int, col: int) -> float:
    """Fingertip z with the rotation's jaw line and the colour heightmap (as the policy's action_pose)."""
    return grasp_z_at(obs, row, col, geometry.primitives, yaw=hm.rotation_yaw(rotation, geometry.heightmap.rotations))


RULES: dict[str, Callable[[hm.Heightmap, Geometry, int, int, int], float]] = {
    "cell": cell_rule,
    "jaw-line": jaw_line_rule,
}


@dataclass(frozen=True)
class Candidate:
    region: str
    row: int
    col: int
    rotation: int


@dataclass
class Trial:
    category: str
    object_id: str
    region: str
    row: int
    col: int
    rotation: int
    cell_height: float  # m
    z: dict[str, float]  # rule -> fingertip z (m)
    success: dict[str, bool]  # rule -> target held after the lift


def _rest_pose(object_id: str, x: float, y: float, yaw: float, lift: float = 0.002) -> tuple[float, ...]:
    from scipy.spatial.transform import Rotation

    from pg_sim.objects.catalog import household_info

    info = household_info(object_id)
    rot = Rotation.from_euler("z", yaw) * Rotation.from_euler("xyz", info.rest_rpy)
    return (x, y, info.extents[2] / 2 + lift, *(float(a) for a in rot.as_euler("xyz")))


def object_ids(category: str, count: int, first: int) -> list[str]:
    """The objects probed for a category: household ids ``first`` .. ``first + count - 1`` (a tilted bowl uses the
    bowls), block shape names for ``block``."""
    if category == "block":
        return [BLOCKS[(first + k) % len(BLOCKS)] for k in range(count)]
    base = "bowl" if category in ("tilted-bowl", "upturned-bowl") else category
    return [f"{base}/{first + k}" for k in range(count)]


def build_scene(world: World, category: str, object_id: str, colour: tuple[int, int, int],
                rng: np.random.Generator) -> SceneSpec:
    """Settle the object (and a tilted bowl's support) in `world`; returns the settled scene (poses at rest)."""
    from scipy.spatial.transform import Rotation

    from pg_sim.objects.catalog import household_info, object_spec
    from pg_sim.scenes.scene import ObjectSpec, SceneSpec

    yaw = float(rng.uniform(-math.pi, math.pi))
    if category == "block":
        obj = ObjectSpec(object_id, None, colour, (0.0, 0.0, 0.05, 0.0, 0.0, yaw), target=True, name="target")
        objs: tuple[ObjectSpec, ...] = (obj,)
    elif category == "tilted-bowl":
        info = household_info(object_id)
        r = info.extents[0] / 2
        heading = yaw
        support = ObjectSpec(TILT_SUPPORT, None, COLORS["brown"],
                             (0.55 * r * math.cos(heading), 0.55 * r * math.sin(heading), 0.0225, 0.0, 0.0, heading),
                             name="support")
        tilt = math.atan2(0.045, 1.4 * r)
        rot = Rotation.from_euler("z", heading) * Rotation.from_euler("y", -tilt)
        pose = (-0.1 * r * math.cos(heading), -0.1 * r * math.sin(heading), info.extents[2] / 2 + 0.03,
                *(float(a) for a in rot.as_euler("xyz")))
        obj = object_spec(object_id, colour, pose, "target", target=True)
        objs = (support, obj)
    elif category == "upturned-bowl":
        info = household_info(object_id)
        rot = Rotation.from_euler("z", yaw) * Rotation.from_euler("xyz", info.rest_rpy) * Rotation.from_euler("x",
                                                                                                            math.pi)
        pose = (0.0, 0.0, info.extents[2] / 2 + 0.003, *(float(a) for a in rot.as_euler("xyz")))
        objs = (object_spec(object_id, colour, pose, "target", target=True),)
    else:
        objs = (object_spec(object_id, colour, _rest_pose(object_id, 0.0, 0.0, yaw), "target", target=True),)
    world.load_scene(SceneSpec(f"probe-{object_id}", "green", objs, family="probe"))
    return world.snapshot(f"probe-{object_id}")


def _nearest_rotation(angle: float, rotations: int) -> int:
    """Rotation index whose closing axis (an axis: angle mod pi) is nearest `angle` (rad)."""
    step = hm.rotation_step(rotations)
    return int(round((angle % math.pi) / step)) % (rotations // 2)


def _distance_to_outline(mask: np.ndarray) -> np.ndarray:
    import cv2

    padded = np.pad(mask.astype(np.uint8), 1)
    return cv2.distanceTransform(padded, cv2.DIST_L2, 5)[1:-1, 1:-1]


def candidates(category: str, obs: hm.Heightmap, mask: np.ndarray, rotations: int, angles: int,
               off_normal: Sequence[int] | None = None) -> list[Candidate]:
    """Candidate grasps (module docstring) on the object's (H, W) bool cells `mask`; `off_normal`: a vessel's band
    cells close at these rotation steps off the radial direction (regions "rim+K", "wall+K", "deep+K") instead of
    0 and 1."""
    res = obs.resolution
    rows, cols = np.nonzero(mask)
    if rows.size == 0:
        return []
    dist = _distance_to_outline(mask) * res  # m to the outline
    out: list[Candidate] = []
    if category == "block":
        r0, c0 = np.unravel_index(int(np.argmax(dist)), dist.shape)
        return [Candidate("centre", int(r0), int(c0), rot) for rot in (0, rotations // 4)]
    if category == "upturned-bowl":
        top = mask & (obs.height >= float(obs.height[mask].max()) - 0.004)
        tr, tc = (int(round(float(a.mean()))) for a in np.nonzero(top))
        return [Candidate("foot", tr + dr, tc + dc, rot) for dr, dc in ((0, 0), (3, 0), (-3, 0), (0, 3), (0, -3))
                for rot in (0, rotations // 4)]
    if category in TOOLS:
        pts = np.column_stack([cols, rows]).astype(np.float64)  # (x, y) cell coordinates
        centre = pts.mean(axis=0)
        _, _, vt = np.linalg.svd(pts - centre, full_matrices=False)
        major = vt[0]
        s = (pts - centre) @ major
        length = float(s.max() - s.min())
        across = _nearest_rotation(math.atan2(major[0], -major[1]), rotations)
        for f in STATIONS:
            near = np.abs(s - (0.5 * (s.max() + s.min()) + f * length)) <= 1.0
            if not near.any():
                continue
            k = np.flatnonzero(near)[int(np.argmax(dist[rows[near], cols[near]]))]
            region = "high" if obs.height[rows[k], cols[k]] >= HIGH_CELL_M else "low"
            for rot in (across, (across + 1) % (rotations // 2)):
                out.append(Candidate(region, int(rows[k]), int(cols[k]), rot))
        return out
    # vessels: rim and inside bands around the object's body centre (the cell farthest from the outline)
    rc, cc = np.unravel_index(int(np.argmax(dist)), dist.shape)
    body_r = float(dist[rc, cc])
    radial = np.hypot(rows - rc, cols - cc) * res
    ang = np.arctan2(rows - rc, cols - cc)
    d = dist[rows, cols]
    handle = (radial > body_r + 0.003) if category == "mug" else np.zeros(rows.size, bool)
    bands = {name: (d >= lo) & (d <= hi) & ~handle for name, (lo, hi) in BANDS.items()}
    for region, band in bands.items():
        if not band.any():
            continue
        for k in range(angles):
            theta = -math.pi + (k + 0.5) * 2 * math.pi / angles
            gap = np.abs(np.angle(np.exp(1j * (ang[band] - theta))))
            pick = np.flatnonzero(band)[int(np.argmin(gap - 1e-3 * radial[band]))]  # nearest angle, outermost
            if np.min(gap) > math.pi / angles:
                continue
            across = _nearest_rotation(float(ang[pick]), rotations)
            if off_normal is not None:
                out += [Candidate(f"{region}+{k}", int(rows[pick]), int(cols[pick]), (across + k) % (rotations // 2))
                        for k in off_normal]
                continue
            for rot in (across, (across + 1) % (rotations // 2)):
                out.append(Candidate(region, int(rows[pick]), int(cols[pick]), rot))
    if category in ("cup", "mug"):
        out += [Candidate("centre", int(rc), int(cc), rot) for rot in (0, rotations // 4)]
    if handle.sum() >= 5:
        hr, hc = rows[handle].mean(), cols[handle].mean()
        k = int(np.argmin(np.hypot(rows[handle] - hr, cols[handle] - hc)))
        r0, c0 = int(rows[handle][k]), int(cols[handle][k])
        radial_rot = _nearest_rotation(math.atan2(r0 - rc, c0 - cc), rotations)
        out += [Candidate("handle", r0, c0, (radial_rot + rotations // 4) % (rotations // 2)),
                Candidate("handle", r0, c0, radial_rot)]
    return out


def probe_object(world: World, category: str, object_id: str, colour: tuple[int, int, int], rules: Sequence[str],
                 angles: int, rng: np.random.Generator, log: Callable[[str], None] | None = None,
                 off_normal: Sequence[int] | None = None) -> list[Trial]:
    """Every candidate grasp of one object under every rule."""
    from pg_sim.world.primitives import PrimitiveExecutor, PrimitiveRefused

    geo = world.geometry
    scene = build_scene(world, category, object_id, colour, rng)
    obs = world.observe()
    target = world.target_id
    labels = world.label_heightmap(obs.frame)
    heightmap = obs.heightmap
    mask = (labels == target) & heightmap.valid
    trials: list[Trial] = []
    for cand in candidates(category, heightmap, mask, geo.heightmap.rotations, angles, off_normal):
        x, y = hm.pixel_to_world(cand.row, cand.col, heightmap.bounds, heightmap.resolution)
        yaw = hm.rotation_yaw(cand.rotation, geo.heightmap.rotations)
        zs = {rule: RULES[rule](heightmap, geo, cand.rotation, cand.row, cand.col) for rule in rules}
        done: dict[float, bool] = {}
        ok: dict[str, bool] = {}
        for rule, z in zs.items():
            key = round(z, 9)
            if key not in done:
                world.load_scene(scene)
                try:
                    done[key] = bool(PrimitiveExecutor(world).grasp(float(x), float(y), float(z), float(yaw))
                                     .target_grasped)
                except PrimitiveRefused:
                    done[key] = False
            ok[rule] = done[key]
        trials.append(Trial(category, object_id, cand.region, cand.row, cand.col, cand.rotation,
                            float(heightmap.height[cand.row, cand.col]), zs, ok))
        if log:
            zs_mm = " ".join(f"{r} z {1000 * z:5.1f} mm {'ok' if ok[r] else '--'}" for r, z in zs.items())
            log(f"  {object_id:14s} {cand.region:7s} cell ({cand.row:3d}, {cand.col:3d}) h "
                f"{1000 * trials[-1].cell_height:5.1f} mm rot {cand.rotation:2d}: {zs_mm}")
    return trials


def run(categories: Sequence[str], objects: int = 4, first: int = 0, rules: Sequence[str] = tuple(RULES),
        angles: int = 4, seed: int = 0, mode: str = DEFAULT_SIM_MODE, geometry: Geometry | None = None,
        log: Callable[[str], None] | None = None, off_normal: Sequence[int] | None = None) -> list[Trial]:
    """Probe `objects` objects of each category (ids from `first`) with every rule; the object yaws come from
    `seed`, the category and the object's index (a subset of categories probes the same scenes); `off_normal`: see
    `candidates`."""
    unknown = [c for c in categories if c not in CATEGORIES]
    if unknown:
        raise ValueError(f"unknown probe categories {unknown}; known: {', '.join(CATEGORIES)}")
    unknown = [r for r in rules if r not in RULES]
    if unknown:
        raise ValueError(f"unknown grasp-height rules {unknown}; known: {', '.join(RULES)}")
    from pg_sim.world.world import World

    trials: list[Trial] = []
    with World(geometry=geometry, mode=mode) as world:
        for c, category in enumerate(CATEGORIES):
            if category not in categories:
                continue
            for k, object_id in enumerate(object_ids(category, objects, first)):
                colour = COLORS[COLOUR_NAMES[(c + k) % len(COLOUR_NAMES)]]
                rng = np.random.default_rng([seed, c, first + k])  # the same scene whatever else is probed
                trials += probe_object(world, category, object_id, colour, rules, angles, rng, log, off_normal)
    return trials


def table(trials: Sequence[Trial], rules: Sequence[str], by_region: bool = False) -> str:
    """Per category (and region): grasps, and per rule the success rate and the mean fingertip z."""
    groups: dict[tuple[str, str], list[Trial]] = {}
    for t in trials:
        groups.setdefault((t.category, t.region if by_region else ""), []).append(t)
    head = f"{'category':12s} {'region':7s} {'grasps':>6s}" + "".join(f" {r + ' ok':>14s} {'z mm':>6s}" for r in rules)
    lines = [head, "-" * len(head)]
    order = {c: i for i, c in enumerate(CATEGORIES)}
    for (cat, region), ts in sorted(groups.items(), key=lambda kv: (order.get(kv[0][0], 99), kv[0][1])):
        row = f"{cat:12s} {region or 'all':7s} {len(ts):6d}"
        for r in rules:
            n = sum(t.success[r] for t in ts)
            row += f" {n:4d} ({100 * n / len(ts):5.1f}%) {1000 * np.mean([t.z[r] for t in ts]):6.1f}"
        lines.append(row)
    total = f"{'all':12s} {'':7s} {len(trials):6d}"
    for r in rules:
        n = sum(t.success[r] for t in trials)
        total += f" {n:4d} ({100 * n / max(len(trials), 1):5.1f}%) {'':6s}"
    lines += ["-" * len(head), total]
    return "\n".join(lines)


def add_arguments(ap: argparse.ArgumentParser) -> None:
    ap.add_argument("categories", nargs="*", default=list(CATEGORIES),
                    help=f"categories to probe (default: all): {' '.join(CATEGORIES)}")
    ap.add_argument("--objects", type=int, default=4, help="objects per category (default 4)")
    ap.add_argument("--first", type=int, default=0, help="index of the first object id (default 0)")
    ap.add_argument("--rules", nargs="+", default=list(RULES), choices=list(RULES),
                    help="grasp-height rules to compare (default: all)")
    ap.add_argument("--angles", type=int, default=4, help="directions around a vessel (default 4)")
    ap.add_argument("--seed", type=int, default=0, help="seed of the object yaws (default 0)")
    ap.add_argument("--sim-mode", choices=list(SIM_MODES), default=DEFAULT_SIM_MODE,
                    help=f"simulation mode (default {DEFAULT_SIM_MODE}, as evaluation)")
    ap.add_argument("--closed-threshold", type=float, default=None, metavar="M",
                    help="override gripper.closed_threshold (m) for a diagnostic run: the jaw counts as holding "
                         "something above this opening (default: the config's)")
    ap.add_argument("--off-normal", default=None, metavar="K,...",
                    help="a vessel's rim, wall and deep cells close at these rotation steps (22.5 deg each) off the "
                         "radial direction, regions named rim+K, wall+K, deep+K (default: 0 and 1, regions unnamed "
                         "by step)")
    ap.add_argument("--by-region", action="store_true", help="one table row per category and region")
    ap.add_argument("--verbose", action="store_true", help="print every grasp")
    ap.add_argument("--out", type=Path, default=None, help="write every grasp as JSON here")


def execute(args: argparse.Namespace) -> int:
    if args.objects < 1 or args.angles < 1:
        raise ValueError(f"--objects and --angles must be >= 1, got {args.objects}, {args.angles}")
    off_normal = None
    if args.off_normal is not None:
        try:
            off_normal = [int(k) for k in str(args.off_normal).split(",")]
        except ValueError:
            raise ValueError(f"--off-normal must be comma-separated rotation steps, got {args.off_normal!r}") from None
        if any(k < 0 or k > 4 for k in off_normal):
            raise ValueError(f"--off-normal steps must lie in 0..4 (0 to 90 deg), got {args.off_normal!r}")
    geometry = load()
    if args.closed_threshold is not None:
        geometry = replace(geometry, gripper=replace(geometry.gripper, closed_threshold=args.closed_threshold))
    t0 = time.perf_counter()
    trials = run(args.categories, args.objects, args.first, args.rules, args.angles, args.seed, args.sim_mode,
                 geometry, log=(lambda s: print(s, flush=True)) if args.verbose else None, off_normal=off_normal)
    print(table(trials, args.rules, args.by_region))
    print(f"{len(trials)} candidate grasps, {time.perf_counter() - t0:.0f} s wall time ({args.sim_mode} mode)")
    if args.out is not None:
        args.out.parent.mkdir(parents=True, exist_ok=True)
        args.out.write_text(json.dumps([asdict(t) for t in trials], indent=1))
        print(f"wrote {args.out}")
    return 0


def main(argv: Sequence[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m pg_sim.world.grasp_probe",
                                 description=(__doc__ or "").splitlines()[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    add_arguments(ap)
    return execute(ap.parse_args(argv))


if __name__ == "__main__":
    sys.exit(main())
