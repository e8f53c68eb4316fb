"""Household arrangements: the target placed where the policy loses it, then clutter dropped around.

Each arrangement returns the objects it places, target first, in spawn order, with poses close to their rest
(pg_sim.world.random_scene.drop_scene spawns them one at a time and settles each, so a later object lands on an
earlier one). Poses are in `world` (m, rad; ROS fixed-axis rpy about the bounding-box centre, as ObjectSpec).

| arrangement | the target ...                                                              |
|-------------|-----------------------------------------------------------------------------|
| under       | lies flat, one or two neighbours (plate, bowl, hammer, toy, spatula) over it  |
| inside      | lies inside a bowl, cup or mug                                             |
| holding     | is a bowl, cup or mug holding another object                               |
| leaning     | leans on a taller standing object (cup, mug, can, bottle)                  |
| thin        | lies under and among 4-5 long thin objects (cutlery, tools) crossing it    |
| edge        | lies 1-2.5 cm inside a workspace edge, neighbours between it and the centre|

The arrangement of a scene is ``ARRANGEMENT_NAMES[seed % 6]`` (``arrangement_of``): any six consecutive seeds
cover each once, so per-arrangement rows of a 100-trial run hold 16-17 trials each.
The families of one arrangement (pg_sim.world.scene_families: ``household-hard-A-N``, ``train-household-hard-A-N``)
pass it to every scene instead.
Sampling needs no simulator: only the catalogue's metadata (pg_sim.objects.catalog.household_info).
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
from scipy.spatial.transform import Rotation

from pg_sim.objects.catalog import HOUSEHOLD_KINDS, household_info, object_spec
from pg_sim.scenes.scene import ObjectSpec, Pose

CONTAINERS = ("bowl", "cup", "mug")
THIN = ("knife", "spoon", "fork", "spatula", "screwdriver", "scissors", "pliers")
COVERS = ("plate", "bowl", "hammer", "toy_airplane", "spatula", "toy_car")
UNDER_TARGETS = (*THIN, "fruit", "brick", "toy_car")
FILLERS = ("fruit", "brick", "spoon", "fork", "knife", "screwdriver", "toy_car", "can")
TALL = ("cup", "mug", "can", "bottle")
LEANERS = ("plate", "spatula", "knife", "spoon", "fork", "screwdriver", "toy_airplane", "hammer")
UNDER_SHIFT = (0.0, 0.5)  # a cover's centre is this fraction of the target's half length from the target's centre
UNDER_SECOND_COVER = 0.5  # probability of a second cover on the first
THIN_SPREAD_M = 0.025  # m: thin neighbours' centres within this (x and y) of the target's: they cross over it
GAP_M = 0.003  # m: vertical clearance of a placed object above what it lands on
KEEP_CLEAR_M = 0.06  # m: clutter is dropped at least this far (xy) from the arrangement's anchor
CLUTTER_HALF_EXTENT = 0.11  # m: clutter drop area, as the novel families
CLUTTER_REACH_CAP_M = 0.06  # m: at most this much of a clutter object's half length is added to KEEP_CLEAR_M
CLUTTER_DROP_GAP_M = 0.02  # m: clutter is dropped with its centre this far above half its length (no bounce)
EDGE_GAP_M = (0.010, 0.025)  # m: the edge target's outer side lies this far inside the workspace edge
WORKSPACE_HALF = 0.224  # m: pg_description workspace.yaml x/y half extent (checked by test_arrangements)
MIN_OBJECTS = 6  # fewest objects of a hard-family scene: the largest arrangement (thin) places six
DRAWS = 40  # attempts to draw an object that fits (a filler narrower than its container, ...)


@dataclass(frozen=True)
class Placed:
    """An object an arrangement places: catalogue id and pose (x, y, z, roll, pitch, yaw in `world`)."""

    object_id: str
    pose: Pose


@dataclass(frozen=True)
class Arranged:
    """The placed objects (target first, spawn order is the list order with the target where ``target_at`` says)
    and the anchor (x, y) in `world` that clutter keeps clear of."""

    placed: tuple[Placed, ...]
    target_at: int
    anchor: tuple[float, float]


CATEGORY_SET = frozenset(HOUSEHOLD_KINDS)
Pool = dict[str, list[str]]  # category -> ids of one split
Arrangement = Callable[[np.random.Generator, Pool], Arranged]


def _pick(rng: np.random.Generator, pool: Pool, categories: Sequence[str],
          fits: Callable[[str], bool] = lambda _: True) -> str:
    """An id of a category drawn uniformly from ``categories`` (those in the pool) that ``fits``; the last draw
    when none of DRAWS fits."""
    cats = [c for c in categories if pool.get(c)]
    if not cats:
        raise ValueError(f"no objects of {', '.join(categories)} in this split")
    choice = ""
    for _ in range(DRAWS):
        cat = cats[int(rng.integers(len(cats)))]
        choice = pool[cat][int(rng.integers(len(pool[cat])))]
        if fits(choice):
            return choice
    return choice


def _rpy(rot: Rotation) -> tuple[float, float, float]:
    """ROS fixed-axis roll, pitch, yaw (rad) of ``rot`` (at pitch +-pi/2 any split of roll and yaw is the same
    rotation: scipy's gimbal-lock warning says so and is silenced)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)
        r, p, y = rot.as_euler("xyz")
    return float(r), float(p), float(y)


def _rest(object_id: str, x: float, y: float, yaw: float, z0: float = 0.0) -> Placed:
    """``object_id`` in its rest pose turned by ``yaw`` about world z, bottom at ``z0`` + GAP_M (``z0``: the top
    of what it lands on, itself placed GAP_M above its own support)."""
    info = household_info(object_id)
    rot = Rotation.from_euler("z", yaw) * Rotation.from_euler("xyz", info.rest_rpy)
    return Placed(object_id, (x, y, z0 + info.extents[2] / 2 + GAP_M, *_rpy(rot)))


def _tilted(object_id: str, x: float, y: float, heading: float, tilt: float, z: float) -> Placed:
    """``object_id`` with its long horizontal axis along ``heading`` (rad about z), raised by ``tilt`` (rad) so its
    far end is up, centre at (x, y, z)."""
    info = household_info(object_id)
    along_y = info.extents[1] > info.extents[0]
    rot = (Rotation.from_euler("z", heading) * Rotation.from_euler("y", -tilt)
           * Rotation.from_euler("z", math.pi / 2 if along_y else 0.0) * Rotation.from_euler("xyz", info.rest_rpy))
    return Placed(object_id, (x, y, z, *_rpy(rot)))


def _anchor(rng: np.random.Generator, half: float = 0.06) -> tuple[float, float]:
    xy = rng.uniform(-half, half, 2)
    return float(xy[0]), float(xy[1])


def under(rng: np.random.Generator, pool: Pool) -> Arranged:
    target = _pick(rng, pool, UNDER_TARGETS)
    x, y = _anchor(rng)
    t = _rest(target, x, y, float(rng.uniform(-math.pi, math.pi)))
    info = household_info(target)
    placed, z0 = [t], GAP_M + info.extents[2]
    for _ in range(1 + int(rng.random() < UNDER_SECOND_COVER)):  # one cover, sometimes a second one on it
        cover = _pick(rng, pool, COVERS, lambda c: household_info(c).length > 0.6 * info.length)
        heading = float(rng.uniform(-math.pi, math.pi))
        shift = 0.5 * info.length * float(rng.uniform(*UNDER_SHIFT))
        placed.append(_rest(cover, x + shift * math.cos(heading), y + shift * math.sin(heading),
                            float(rng.uniform(-math.pi, math.pi)), z0=z0))
        z0 += household_info(cover).extents[2] + GAP_M
    return Arranged(tuple(placed), 0, (x, y))


def _fits_in(container: str) -> Callable[[str], bool]:
    inner = household_info(container).inner_radius
    return lambda obj: max(household_info(obj).extents[:2]) < 1.7 * inner


def inside(rng: np.random.Generator, pool: Pool) -> Arranged:
    container = _pick(rng, pool, CONTAINERS)
    x, y = _anchor(rng)
    c = _rest(container, x, y, float(rng.uniform(-math.pi, math.pi)))
    info = household_info(container)
    target = _pick(rng, pool, FILLERS, _fits_in(container))
    t = _rest(target, x, y, float(rng.uniform(-math.pi, math.pi)), z0=GAP_M + info.extents[2] - info.inner_depth)
    return Arranged((c, t), 1, (x, y))


def holding(rng: np.random.Generator, pool: Pool) -> Arranged:
    arranged = inside(rng, pool)
    return Arranged(arranged.placed, 0, arranged.anchor)  # the container is the target


def leaning(rng: np.random.Generator, pool: Pool) -> Arranged:
    support = _pick(rng, pool, TALL, lambda s: household_info(s).extents[2] > 0.06)
    sx, sy = _anchor(rng)
    s = _rest(support, sx, sy, float(rng.uniform(-math.pi, math.pi)))
    sinfo = household_info(support)
    target = _pick(rng, pool, LEANERS, lambda t: household_info(t).length > 1.2 * sinfo.extents[2])
    length = household_info(target).length
    tilt = math.asin(min(0.85, sinfo.extents[2] / length))
    heading = float(rng.uniform(-math.pi, math.pi))  # from the target's centre towards the support
    reach = max(sinfo.extents[:2]) / 2 + 0.5 * length * math.cos(tilt)
    x, y = sx - reach * math.cos(heading), sy - reach * math.sin(heading)
    z = 0.5 * length * math.sin(tilt) + household_info(target).extents[2] / 2 + GAP_M
    return Arranged((s, _tilted(target, x, y, heading, tilt, z)), 1, (x, y))


def thin(rng: np.random.Generator, pool: Pool) -> Arranged:
    target_cats = THIN if rng.random() < 0.5 else tuple(pool)
    target = _pick(rng, pool, target_cats)
    x, y = _anchor(rng)
    placed = [_rest(target, x, y, float(rng.uniform(-math.pi, math.pi)))]
    z0 = GAP_M + household_info(target).extents[2]
    for _ in range(int(rng.integers(4, 6))):
        other = _pick(rng, pool, THIN)
        dx, dy = rng.uniform(-THIN_SPREAD_M, THIN_SPREAD_M, 2)
        placed.append(_rest(other, x + float(dx), y + float(dy), float(rng.uniform(-math.pi, math.pi)), z0=z0))
        z0 += household_info(other).extents[2] + GAP_M
    return Arranged(tuple(placed), 0, (x, y))


def edge(rng: np.random.Generator, pool: Pool) -> Arranged:
    target = _pick(rng, pool, tuple(pool), lambda t: household_info(t).length < 0.16)
    info = household_info(target)
    yaw = float(rng.uniform(-math.pi, math.pi))
    half = math.hypot(info.extents[0], info.extents[1]) / 2  # the footprint's half diagonal, whatever the yaw
    side = int(rng.integers(4))  # +x, -x, +y, -y
    inward = WORKSPACE_HALF - half - float(rng.uniform(*EDGE_GAP_M))
    along = float(rng.uniform(-0.15, 0.15))
    x, y = [(inward, along), (-inward, along), (along, inward), (along, -inward)][side]
    placed = [_rest(target, x, y, yaw)]
    n = np.array([x, y]) / max(math.hypot(x, y), 1e-9)
    for k in range(int(rng.integers(2, 4))):  # neighbours between it and the centre
        d = half + 0.03 + 0.04 * k
        other = _pick(rng, pool, tuple(pool), lambda o: household_info(o).length < 0.16)
        placed.append(_rest(other, x - d * float(n[0]) + float(rng.uniform(-0.03, 0.03)),
                            y - d * float(n[1]) + float(rng.uniform(-0.03, 0.03)), float(rng.uniform(-3, 3))))
    return Arranged(tuple(placed), 0, (x, y))


ARRANGEMENTS: dict[str, Arrangement] = {
    "under": under, "inside": inside, "holding": holding, "leaning": leaning, "thin": thin, "edge": edge,
}
ARRANGEMENT_NAMES = tuple(ARRANGEMENTS)


def arrangement_of(seed: int) -> str:
    """The arrangement of a hard-family scene drawn with ``seed``."""
    return ARRANGEMENT_NAMES[int(seed) % len(ARRANGEMENT_NAMES)]


def arranged_objects(rng: np.random.Generator, pool: Pool, n: int, seed: int, colors: Sequence[tuple[int, int, int]],
                     target_color: tuple[int, int, int], draw_clutter: Callable[[np.random.Generator], str],
                     arrangement: str | None = None) -> list[ObjectSpec]:
    """The n objects of a hard-family scene in spawn order: `arrangement` (one of ARRANGEMENT_NAMES; None: the
    arrangement of ``seed``) with the target green, then clutter ids from ``draw_clutter`` dropped at least
    KEEP_CLEAR_M plus half their length (at most CLUTTER_REACH_CAP_M) from its anchor, from just above their half
    length. ``colors`` are the non-target colours to draw from. Objects are named ``obj<i>-<category>-<index>`` with
    obj0 the target. Raises ValueError for n < MIN_OBJECTS or an unknown arrangement."""
    if n < MIN_OBJECTS:
        raise ValueError(f"an arranged scene needs at least {MIN_OBJECTS} objects, got {n}")
    if arrangement is not None and arrangement not in ARRANGEMENTS:
        raise ValueError(f"unknown arrangement {arrangement!r} (known: {', '.join(ARRANGEMENT_NAMES)})")
    arranged = ARRANGEMENTS[arrangement or arrangement_of(seed)](rng, pool)
    placed = list(arranged.placed)
    order = [arranged.target_at] + [i for i in range(len(placed)) if i != arranged.target_at]
    objects: list[ObjectSpec | None] = [None] * len(placed)
    for rank, k in enumerate(order):  # rank 0 is the target
        color = target_color if rank == 0 else colors[int(rng.integers(len(colors)))]
        objects[k] = object_spec(placed[k].object_id, color, placed[k].pose,
                                 f"obj{rank}-{placed[k].object_id.replace('/', '-')}", target=rank == 0)
    out = [o for o in objects if o is not None]
    ax, ay = arranged.anchor
    for i in range(len(out), n):
        object_id = draw_clutter(rng)
        reach = household_info(object_id).length / 2 if object_id.split("/")[0] in CATEGORY_SET else 0.05
        clear = KEEP_CLEAR_M + min(reach, CLUTTER_REACH_CAP_M)
        best, xy = -1.0, np.zeros(2)
        for _ in range(DRAWS):  # the first drop point clear of the anchor, else the farthest one drawn
            cand = rng.uniform(-CLUTTER_HALF_EXTENT, CLUTTER_HALF_EXTENT, 2)
            dist = math.hypot(float(cand[0]) - ax, float(cand[1]) - ay)
            if dist > best:
                best, xy = dist, cand
            if dist >= clear:
                break
        rpy = rng.uniform(-np.pi, np.pi, 3)
        pose = (float(xy[0]), float(xy[1]), reach + CLUTTER_DROP_GAP_M, *(float(a) for a in rpy))
        out.append(object_spec(object_id, colors[int(rng.integers(len(colors)))], pose,
                               f"obj{i}-{object_id.replace('/', '-')}"))
    return out
