"""Household objects as users have them: 18 categories of generated meshes with real sizes, masses and friction.

An id is ``<category>/<index>``, index 0-99; indices 0-79 are the training split, 80-99 the held-out split. The
generator of an object is seeded by (zlib.crc32(category), index), so an id always gives the same object. It draws
first the category's main dimension and shape variant for the split (``split_params``), then its friction, then the
builder's further dimensions. Held-out objects take their main dimension from a band that no training object uses
and may take a variant (marked *) that no training object has:

| category     | main dimension (m)  | range       | held-out band | variants (other dimensions)              |
|--------------|---------------------|-------------|---------------|------------------------------------------|
| bowl         | outer diameter      | 0.10-0.20   | 0.140-0.155   | round (h 0.3-0.45 d, wall 3-5 mm, foot)  |
| plate        | diameter            | 0.15-0.26   | 0.190-0.210   | ceramic, melamine (15-25 mm high)        |
| cup          | height              | 0.07-0.12   | 0.090-0.100   | straight, tapered (top d 0.06-0.082)     |
| mug          | height              | 0.075-0.11  | 0.090-0.097   | round handle, square handle* (d .07-.085)|
| bottle       | height              | 0.15-0.28   | 0.200-0.220   | standing, lying (d 0.05-0.08)            |
| can          | height              | 0.07-0.16   | 0.110-0.120   | standing, lying (d 0.052-0.075)          |
| spoon        | length              | 0.15-0.20   | 0.170-0.178   | oval, round bowl                         |
| fork         | length              | 0.17-0.21   | 0.185-0.193   | three, four tines                        |
| knife        | length              | 0.18-0.25   | 0.210-0.220   | table, chef (blade 1-3 mm thick)         |
| spatula      | length              | 0.22-0.29   | 0.250-0.260   | solid, slotted*                          |
| screwdriver  | length              | 0.12-0.26   | 0.180-0.195   | flat, phillips                           |
| scissors     | length              | 0.13-0.21   | 0.165-0.175   | pointed, blunt                           |
| pliers       | length              | 0.14-0.22   | 0.170-0.180   | combination, needle*                     |
| hammer       | length              | 0.20-0.295  | 0.245-0.255   | claw, peen, mallet*                      |
| toy_airplane | length              | 0.10-0.18   | 0.135-0.145   | prop (on wheels), jet*                   |
| toy_car      | length              | 0.06-0.13   | 0.090-0.097   | sedan, van, pickup*                      |
| brick        | stud pitch          | 0.008-0.016 | 0.0115-0.0125 | 1x2, 2x2, 1x3, 1x4, 2x4, 2x3*            |
| fruit        | size in its range   | 0-1         | 0.45-0.60     | apple, orange, banana, pear*             |

Every object fits the parallel jaw (0.085 m open) somewhere: across its body, rim, handle, blade or wall.

Meshes: each builder returns convex pieces (pg_sim.objects.household_shapes; builders in household_vessels,
household_tools, household_toys); the visual mesh is their boolean union (watertight), so the collision decomposition
is exact by construction and concave objects (bowls, plates, cups, mugs, the can's rim, the brick's underside, the
spoon's bowl) keep their cavity in physics. The catalogue (pg_sim.objects.catalog) caches the files. Building one
object and writing its files (union, Bullet-margin inset and .obj export included) takes 0.01-0.35 s on one core:
bowls (~90 pieces) 0.3 s, plates 0.2 s, cups and mugs 0.15 s, the rest under 0.13 s; mean 0.07 s (measured over
ids 0, 10, ..., 90 of every category). Two limits of PyBullet's mesh objects remain: pieces thinner than 2.5 of
Bullet's 1 mm margins (knife blades, tines) collide up to ~1.5 mm thicker than they look, and the centre of mass is
the bounding-box centre, so a screwdriver settles leaning a few degrees onto its tip.

Masses: the union's volume per material group times its density (ceramic, steel, wood, plastic, ...; closed bottles
and cans an effective density), clipped to ``MASS_RANGE``. Friction: a lateral friction coefficient drawn per object
from the category's range.
"""

from __future__ import annotations

import zlib
from dataclasses import dataclass

import numpy as np
import trimesh
from scipy.spatial.transform import Rotation

from pg_sim.objects import household_shapes as shapes
from pg_sim.objects import household_tools as tools
from pg_sim.objects import household_toys as toys
from pg_sim.objects import household_vessels as vessels
from pg_sim.objects.household_shapes import Builder, Draw, union

INDEX_COUNT = 100  # ids <category>/0 .. /99
HELD_OUT_FROM = 80  # index >= 80: held-out split
MASS_RANGE = (0.005, 0.6)  # kg


@dataclass(frozen=True)
class Category:
    """A category: its builder, main dimension (name, range, held-out band, m unless stated), shape variants (those in
    ``held_variants`` for held-out ids only), lateral friction range, and what arrangements need to know."""

    builder: Builder
    main: str
    span: tuple[float, float]
    held: tuple[float, float]
    variants: tuple[str, ...]
    friction: tuple[float, float]
    held_variants: tuple[str, ...] = ()
    container: bool = False  # can hold a small object
    thin: bool = False  # long and thin


def _c(builder: Builder, main: str, span: tuple[float, float], held: tuple[float, float], variants: str,
       friction: tuple[float, float], held_variants: str = "", container: bool = False, thin: bool = False) -> Category:
    return Category(builder, main, span, held, tuple(variants.split()), friction, tuple(held_variants.split()),
                    container, thin)


CATEGORIES: dict[str, Category] = {
    "bowl": _c(vessels.bowl, "diameter", (0.10, 0.20), (0.14, 0.155), "round", (0.45, 0.65), container=True),
    "plate": _c(vessels.plate, "diameter", (0.15, 0.26), (0.19, 0.21), "ceramic melamine", (0.4, 0.6),
                container=True),
    "cup": _c(vessels.cup, "height", (0.07, 0.12), (0.09, 0.10), "straight tapered", (0.4, 0.6), container=True),
    "mug": _c(vessels.mug, "height", (0.075, 0.11), (0.09, 0.097), "round square", (0.45, 0.65), "square",
              container=True),
    "bottle": _c(vessels.bottle, "height", (0.15, 0.28), (0.20, 0.22), "standing lying", (0.3, 0.5)),
    "can": _c(vessels.can, "height", (0.07, 0.16), (0.11, 0.12), "standing lying", (0.3, 0.45)),
    "spoon": _c(tools.spoon, "length", (0.15, 0.20), (0.17, 0.178), "oval round", (0.25, 0.4), thin=True),
    "fork": _c(tools.fork, "length", (0.17, 0.21), (0.185, 0.193), "three four", (0.25, 0.4), thin=True),
    "knife": _c(tools.knife, "length", (0.18, 0.25), (0.21, 0.22), "table chef", (0.25, 0.4), thin=True),
    "spatula": _c(tools.spatula, "length", (0.22, 0.29), (0.25, 0.26), "solid slotted", (0.5, 0.8), "slotted",
                  thin=True),
    "screwdriver": _c(tools.screwdriver, "length", (0.12, 0.26), (0.18, 0.195), "flat phillips", (0.5, 0.8),
                      thin=True),
    "scissors": _c(tools.scissors, "length", (0.13, 0.21), (0.165, 0.175), "pointed blunt", (0.35, 0.5), thin=True),
    "pliers": _c(tools.pliers, "length", (0.14, 0.22), (0.17, 0.18), "combination needle", (0.4, 0.6), "needle",
                 thin=True),
    "hammer": _c(tools.hammer, "length", (0.20, 0.295), (0.245, 0.255), "claw peen mallet", (0.5, 0.8), "mallet"),
    "toy_airplane": _c(toys.toy_airplane, "length", (0.10, 0.18), (0.135, 0.145), "prop jet", (0.4, 0.6), "jet"),
    "toy_car": _c(toys.toy_car, "length", (0.06, 0.13), (0.09, 0.097), "sedan van pickup", (0.5, 0.7), "pickup"),
    "brick": _c(toys.brick, "stud_pitch", (0.008, 0.016), (0.0115, 0.0125), "1x2 2x2 1x3 1x4 2x4 2x3", (0.35, 0.5),
                "2x3"),
    "fruit": _c(toys.fruit, "size", (0.0, 1.0), (0.45, 0.6), "apple orange banana pear", (0.5, 0.8), "pear"),
}
CATEGORY_NAMES = tuple(CATEGORIES)
SOURCES = (shapes, vessels, tools, toys)  # the builders: the catalogue keys its cache by their code and this module's


@dataclass(frozen=True)
class HouseholdInfo:
    """What arrangements need of a household object. ``extents``: bounding box (m) of the nominal mesh in its resting
    pose; ``rest_rpy``: roll, pitch, yaw (rad, ROS fixed axes, about the mesh's bounding-box centre) of that pose, in
    which the object stands upright (a bowl opening up), its lowest point ``extents[2] / 2`` below its frame;
    ``container``: it can hold a small object (``inner_radius``: of the inside at the rim, a plate's flat well;
    ``inner_depth``: from the inside bottom to the rim; m, 0 for other objects);
    ``thin``: a long thin object; ``length``: its longest extent (m)."""

    category: str
    extents: tuple[float, float, float]
    container: bool
    thin: bool
    length: float
    rest_rpy: tuple[float, float, float]
    inner_radius: float
    inner_depth: float
    variant: str = ""
    mass: float = 0.0  # kg
    friction: float = 0.0  # lateral friction coefficient


@dataclass
class Model:
    """A built household object: convex pieces and the visual mesh (m, centred on the bounding-box centre of the
    canonical pose), mass (kg), friction and its info."""

    parts: list[trimesh.Trimesh]
    visual: trimesh.Trimesh
    params: dict[str, float | str]
    info: HouseholdInfo


def _rng(category: str, index: int) -> np.random.Generator:
    return np.random.default_rng([zlib.crc32(category.encode()), index])


def _check(category: str, index: int) -> Category:
    if category not in CATEGORIES:
        raise ValueError(f"unknown household category {category[:40]!r}; known: {', '.join(CATEGORIES)}")
    if not 0 <= index < INDEX_COUNT:
        raise ValueError(f"household index must be in [0, {INDEX_COUNT}), got {index}")
    return CATEGORIES[category]


def _split_draw(cat: Category, heldout: bool, rng: np.random.Generator) -> tuple[float, str]:
    lo, hi = cat.span
    h0, h1 = cat.held
    if heldout:
        main = h0 + (h1 - h0) * float(rng.random())
        options = cat.variants
    else:  # uniform over the span less the held-out band
        u = ((h0 - lo) + (hi - h1)) * float(rng.random())
        main = lo + u if u < h0 - lo else h1 + (u - (h0 - lo))
        options = tuple(v for v in cat.variants if v not in cat.held_variants)
    return main, options[int(rng.integers(len(options)))]


def split_params(category: str, index: int) -> tuple[float, str]:
    """(main dimension, variant) of object ``category/index``: what decides its split (module docstring). Raises
    ValueError for an unknown category or an index outside 0-99."""
    cat = _check(category, index)
    return _split_draw(cat, index >= HELD_OUT_FROM, _rng(category, index))


def build(category: str, index: int) -> Model:
    """Build object ``category/index`` (deterministic). Raises ValueError for a bad id, RuntimeError if its visual
    mesh is not watertight (a builder bug)."""
    cat = _check(category, index)
    rng = _rng(category, index)
    main, variant = _split_draw(cat, index >= HELD_OUT_FROM, rng)
    friction = float(rng.uniform(*cat.friction))
    draw = Draw(rng, main, variant, {cat.main: main, "variant": variant})
    shape = cat.builder(draw)
    parts = shape.parts
    lo = np.min([p.bounds[0] for p in parts], axis=0)
    hi = np.max([p.bounds[1] for p in parts], axis=0)
    centre = (lo + hi) / 2
    for p in parts:
        p.apply_translation(-centre)
    visual = union(parts)
    if not visual.is_watertight:
        raise RuntimeError(f"{category}/{index}: the union of its pieces is not watertight")
    groups = shape.groups
    mass = sum((visual if len(groups) == 1 else union(g)).volume * density for g, density in groups)
    rot = Rotation.from_euler("xyz", shape.rest_rpy).as_matrix()  # fixed-axis roll, pitch, yaw (as PyBullet's)
    v = visual.vertices @ rot.T
    ext = v.max(axis=0) - v.min(axis=0)
    info = HouseholdInfo(
        category=category, extents=(float(ext[0]), float(ext[1]), float(ext[2])), container=cat.container,
        thin=cat.thin, length=float(ext.max()), rest_rpy=tuple(float(a) for a in shape.rest_rpy),  # type: ignore[arg-type]
        inner_radius=float(shape.inner_radius), inner_depth=float(shape.inner_depth), variant=variant,
        mass=float(np.clip(mass, *MASS_RANGE)), friction=friction)
    return Model(parts, visual, draw.params, info)
