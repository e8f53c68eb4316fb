"""Scene families generated from a seed: ``<family>-N`` names N objects dropped over the workspace and settled.

| family              | objects                                        | dropped over |
|---------------------|------------------------------------------------|--------------|
| random-N            | blocks                                         | +-0.11 m     |
| dense-N             | blocks (training clutter for pushes)           | +-0.05 m     |
| novel-N             | held-out catalogue objects                     | +-0.11 m     |
| novel-packed-N      | held-out catalogue objects                     | +-0.05 m     |
| mixed-N             | blocks and held-out objects, half each         | +-0.11 m     |
| train-novel-N       | training catalogue objects                     | +-0.11 m     |
| train-novel-packed-N| training catalogue objects                     | +-0.05 m     |
| train-mixed-N       | blocks and training objects, half each         | +-0.11 m     |
| household-N         | held-out household objects at real size        | +-0.11 m     |
| household-hard-N    | held-out household objects, target arranged    | see below    |
| train-household-N   | training household objects                     | +-0.11 m     |
| train-household-hard-N | training household objects, target arranged | see below    |
| household-hard-A-N, train-household-hard-A-N | the same, every scene arrangement A | see below |

Catalogue objects (pg_sim.objects.catalog) are drawn kind first (uniform over the kinds), then an id of that kind in
the family's split, so every kind is equally likely whatever its number of ids. Household families draw from the
household categories (pg_sim.objects.household) and pybullet_data's named meshes the same way, category first.
Hard families (N >= 6) place the target in one of the arrangements of pg_sim.world.arrangements (under a
neighbour, inside or holding a container, leaning, among thin objects, at the workspace edge; ``arrangement_of(seed)``)
and drop the other objects around it. ``household-hard-A-N`` and ``train-household-hard-A-N``, A one of the
arrangement names (e.g. ``train-household-hard-under-8``), arrange every scene as A: sets of one failure mode, as
many trials as wanted. Object 0 is the target (green); the
others take the other palette colours. Objects are named ``obj<i>-<kind>-<index>`` (``obj<i>-<shape>`` for blocks),
so records name the target's kind. The same name and seed give the same scene; another name (family or N) with
the same seed draws other objects.
"""

from __future__ import annotations

import re
import zlib
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from pg_sim.objects.catalog import HOUSEHOLD_KINDS, KINDS, household_ids, object_ids, object_spec
from pg_sim.scenes.colors import COLORS, resolve_color
from pg_sim.scenes.scene import ObjectSpec, SceneSpec
from pg_sim.world.arrangements import ARRANGEMENT_NAMES, arranged_objects
from pg_sim.world.arrangements import MIN_OBJECTS as MIN_ARRANGED
from pg_sim.world.random_scene import BLOCKS, drop_scene, sample_drops

if TYPE_CHECKING:  # a type only: scene sampling needs no simulator
    from pg_sim.world.world import World

MAX_OBJECTS = 40  # largest generated scene


@dataclass(frozen=True)
class Family:
    """A generated family: catalogue split (None = blocks only), share of blocks, drop half-extent (m), which
    objects (``catalogue``: the novel kinds; ``household``: household categories and named meshes), whether the
    target is arranged (pg_sim.world.arrangements) instead of dropped, and the one arrangement of every scene (None:
    the seed's, ``arrangement_of``)."""

    split: str | None
    block_share: float
    half_extent: float
    objects: str = "catalogue"
    arranged: bool = False
    arrangement: str | None = None


FAMILIES: dict[str, Family] = {
    "random": Family(None, 1.0, 0.11),
    "dense": Family(None, 1.0, 0.05),
    "novel": Family("heldout", 0.0, 0.11),
    "novel-packed": Family("heldout", 0.0, 0.05),
    "mixed": Family("heldout", 0.5, 0.11),
    "train-novel": Family("train", 0.0, 0.11),
    "train-novel-packed": Family("train", 0.0, 0.05),
    "train-mixed": Family("train", 0.5, 0.11),
    "household": Family("heldout", 0.0, 0.11, "household"),
    "household-hard": Family("heldout", 0.0, 0.11, "household", arranged=True),
    "train-household": Family("train", 0.0, 0.11, "household"),
    "train-household-hard": Family("train", 0.0, 0.11, "household", arranged=True),
}
for _name in ARRANGEMENT_NAMES:  # one arrangement for every scene of the family
    FAMILIES[f"household-hard-{_name}"] = Family("heldout", 0.0, 0.11, "household", True, _name)
    FAMILIES[f"train-household-hard-{_name}"] = Family("train", 0.0, 0.11, "household", True, _name)
GENERATED = re.compile(r"^(" + "|".join(sorted(map(re.escape, FAMILIES), key=len, reverse=True)) + r")-(\d+)$")


def parse_generated(name: str) -> tuple[str, int] | None:
    """(family, N) of a generated scene name, or None when ``name`` is not one."""
    m = GENERATED.match(str(name))
    return (m.group(1), int(m.group(2))) if m else None


def check_generated(name: str) -> tuple[str, int]:
    """(family, N) of a generated name; raises ValueError when N is outside [1, MAX_OBJECTS] or it is not one."""
    parsed = parse_generated(name)
    if parsed is None:
        raise ValueError(f"{str(name)[:60]!r} is not a generated scene; families: "
                         + ", ".join(f"{f}-N" for f in FAMILIES))
    low = MIN_ARRANGED if FAMILIES[parsed[0]].arranged else 1
    if not low <= parsed[1] <= MAX_OBJECTS:
        raise ValueError(f"{name}: a {parsed[0]} scene needs {low} to {MAX_OBJECTS} objects, got {parsed[1]}")
    return parsed


def sample_family(name: str, seed: int, target: str = "green") -> SceneSpec:
    """The drops (unsettled poses) of generated scene ``name`` for ``seed``. Raises ValueError for a bad name."""
    family_name, n = check_generated(name)
    fam = FAMILIES[family_name]
    if fam.split is None:
        return sample_drops(n, seed, target, half_extent=fam.half_extent)  # as block scenes always were
    rng = np.random.default_rng([seed, zlib.crc32(name.encode())])  # families with the same seed draw differently
    others = [c for c in COLORS if c != target]
    if fam.objects == "household":
        return _household(name, family_name, fam, n, seed, rng, target, others)
    ids = object_ids(fam.split)
    objects: list[ObjectSpec] = []
    for i in range(n):
        xy = rng.uniform(-fam.half_extent, fam.half_extent, 2)
        rpy = rng.uniform(-np.pi, np.pi, 3)
        pose = (float(xy[0]), float(xy[1]), 0.12, *(float(a) for a in rpy))
        color = resolve_color(target if i == 0 else others[int(rng.integers(len(others)))])
        if rng.random() < fam.block_share:
            shape = BLOCKS[int(rng.integers(len(BLOCKS)))]
            objects.append(ObjectSpec(shape, None, color, pose, None, i == 0, f"obj{i}-{shape}"))
            continue
        kind = KINDS[int(rng.integers(len(KINDS)))]
        object_id = ids[kind][int(rng.integers(len(ids[kind])))]
        objects.append(object_spec(object_id, color, pose, f"obj{i}-{object_id.replace('/', '-')}", target=i == 0))
    order = rng.permutation(n)  # the target is not always dropped first (buried) or last (on top)
    return SceneSpec(name=f"{name}-seed{seed}", target=target, objects=tuple(objects[k] for k in order),
                     family=family_name)


def household_pool(split: str) -> dict[str, list[str]]:
    """{category: ids} of the household categories and the named meshes in ``split``."""
    return {**household_ids(split), **object_ids(split, ("named",))}


def _household(name: str, family_name: str, fam: Family, n: int, seed: int, rng: np.random.Generator, target: str,
               others: list[str]) -> SceneSpec:
    """A household family's scene: category first (uniform), then an id; arranged families spawn in the
    arrangement's order (no shuffle: a later object lands on an earlier one)."""
    assert fam.split is not None
    pool = household_pool(fam.split)
    cats = sorted(pool)

    def draw(r: np.random.Generator) -> str:
        cat = cats[int(r.integers(len(cats)))]
        return pool[cat][int(r.integers(len(pool[cat])))]

    colors = [resolve_color(c) for c in others]
    if fam.arranged:
        objects = arranged_objects(rng, {c: pool[c] for c in HOUSEHOLD_KINDS if c in pool}, n, seed, colors,
                                   resolve_color(target), draw, fam.arrangement)
        return SceneSpec(name=f"{name}-seed{seed}", target=target, objects=tuple(objects), family=family_name)
    objects = []
    for i in range(n):
        xy = rng.uniform(-fam.half_extent, fam.half_extent, 2)
        rpy = rng.uniform(-np.pi, np.pi, 3)
        pose = (float(xy[0]), float(xy[1]), 0.12, *(float(a) for a in rpy))
        color = resolve_color(target) if i == 0 else colors[int(rng.integers(len(colors)))]
        object_id = draw(rng)
        objects.append(object_spec(object_id, color, pose, f"obj{i}-{object_id.replace('/', '-')}", target=i == 0))
    order = rng.permutation(n)
    return SceneSpec(name=f"{name}-seed{seed}", target=target, objects=tuple(objects[k] for k in order),
                     family=family_name)


def generate_scene(world: World, name: str, seed: int) -> SceneSpec:
    """Drop generated scene ``name`` for ``seed`` into ``world`` (emptied first) and settle; returns the scene."""
    return drop_scene(world, sample_family(name, seed))


def target_kind(object_name: str) -> str:
    """The kind of an object from its generated name (``obj3-thin-812`` -> thin, ``obj0-cube`` -> block)."""
    parts = object_name.split("-")
    return parts[1] if len(parts) > 2 and (parts[1] in KINDS or parts[1] in HOUSEHOLD_KINDS) else "block"
