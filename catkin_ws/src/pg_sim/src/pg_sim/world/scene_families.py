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

Catalogue objects (pg_sim.objects.catalog) are drawn kind first (uniform over the kinds), then an id of that kind in
the family's split, so every kind is equally likely whatever its number of ids. Object 0 is the target (green); the
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

from pg_sim.objects.catalog import KINDS, object_ids, object_spec
from pg_sim.scenes.colors import COLORS, resolve_color
from pg_sim.scenes.scene import ObjectSpec, SceneSpec
from pg_sim.world.random_scene import BLOCKS, drop_scene, sample_drops

if TYPE_CHECKING:  # a type only: scene sampling needs no simulator
    from pg_sim.world.world import World

MAX_OBJECTS = 40  # largest generated scene


@dataclass(frozen=True)
class Family:
    """A generated family: catalogue split (None = blocks only), share of blocks, drop half-extent (m)."""

    split: str | None
    block_share: float
    half_extent: float


FAMILIES: dict[str, Family] = {
    "random": Family(None, 1.0, 0.11),
    "dense": Family(None, 1.0, 0.05),
    "novel": Family("heldout", 0.0, 0.11),
    "novel-packed": Family("heldout", 0.0, 0.05),
    "mixed": Family("heldout", 0.5, 0.11),
    "train-novel": Family("train", 0.0, 0.11),
    "train-novel-packed": Family("train", 0.0, 0.05),
    "train-mixed": Family("train", 0.5, 0.11),
}
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
    if not 1 <= parsed[1] <= MAX_OBJECTS:
        raise ValueError(f"{name}: a generated scene needs 1 to {MAX_OBJECTS} objects, got {parsed[1]}")
    return parsed


def sample_family(name: str, seed: int, target: str = "green") -> SceneSpec:
    """The drops (unsettled poses) of generated scene ``name`` for ``seed``. Raises ValueError for a bad name."""
    family_name, n = check_generated(name)
    fam = FAMILIES[family_name]
    if fam.split is None:
        return sample_drops(n, seed, target, half_extent=fam.half_extent)  # as block scenes always were
    rng = np.random.default_rng([seed, zlib.crc32(name.encode())])  # families with the same seed draw differently
    ids = object_ids(fam.split)
    others = [c for c in COLORS if c != target]
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


def generate_scene(world: World, name: str, seed: int) -> SceneSpec:
    """Drop generated scene ``name`` for ``seed`` into ``world`` (emptied first) and settle; returns the scene."""
    return drop_scene(world, sample_family(name, seed))


def target_kind(object_name: str) -> str:
    """The kind of an object from its generated name (``obj3-thin-812`` -> thin, ``obj0-cube`` -> block)."""
    parts = object_name.split("-")
    return parts[1] if len(parts) > 2 and parts[1] in KINDS else "block"
