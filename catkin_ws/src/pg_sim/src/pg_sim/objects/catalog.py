"""The object catalogue: every non-block object a scene can use, by id, with its training / held-out split.

An object id is ``<kind>/<index>``:
- generated kinds (pg_sim.objects.generated: thin, rod, rolling, concave, small, wide): index 0-999, dimensions drawn
  from a generator seeded by (kind, index). Split by index: 0-799 training, 800-999 held-out.
- ``blob/<index>``: pybullet_data's procedural ``random_urdfs`` (0-999, less the broken ones of
  pybullet_assets.BROKEN_BLOBS). Split by index: 0-799 training, 800-999 held-out.
- ``named/<name>``: pybullet_data's named meshes (pg_sim.objects.pybullet_assets.NAMED). Split by name:
  held-out ``NAMED_HELD_OUT`` (duck, bunny, teddy, mug, torus), training the rest.
- household categories (pg_sim.objects.household, ``HOUSEHOLD_KINDS``: bowl, plate, cup, mug, ..., fruit): index
  0-99; 0-79 training, 80-99 held-out, drawn from main dimensions and shape variants no training object has. They
  are not among ``KINDS``: the generated scene families (``object_ids(split)``) draw as before; ask for them with
  ``household_ids(split)`` or ``object_ids(split, HOUSEHOLD_KINDS)``. ``household_info`` gives what arrangements need.
Held-out objects are never trained on: the training scene families draw from ``object_ids("train")`` only.

``object_spec`` turns an id into an ObjectSpec of shape ``mesh``; generated meshes are written once to
``<cache>/objects/`` (``PUSHGRASP_CACHE``, default ``~/.cache/pushgrasp``): ``<kind>-<index>-v<N>.obj`` with the
nominal parts (what the camera sees) and its collision companion ``....collision.obj`` whose groups are the parts
inset by Bullet's margin, so PyBullet collides with a compound of exact hulls at the nominal surface. Household
objects are cached the same way, with a ``.json`` of their mass, friction and ``HouseholdInfo`` beside them:
``household-<category>-<index>-v<N>-<digest of the builders' source>.obj`` is the watertight union of their convex
pieces, its ``.collision.obj`` the pieces inset.
"""

from __future__ import annotations

import hashlib
import json
import os
import zlib
from dataclasses import asdict
from functools import lru_cache
from pathlib import Path

import numpy as np
import trimesh

from pg_sim.objects import generated, household
from pg_sim.objects.household import HouseholdInfo
from pg_sim.objects.pybullet_assets import BLOB_COUNT, BLOB_SCALE, BROKEN_BLOBS, NAMED, blob_path, data_path
from pg_sim.scenes.meshes import collision_file, load_obj, mesh_volume
from pg_sim.scenes.scene import ObjectSpec, Pose
from pg_sim.scenes.shapes import cache_dir

SPLITS = ("train", "heldout")
HELD_OUT_FROM = 800  # generated kinds and blobs: index >= 800 is held out
INDEX_COUNT = 1000
NAMED_HELD_OUT = ("duck", "bunny", "teddy", "mug", "torus")
GENERATED_KINDS = tuple(generated.BUILDERS)
KINDS = (*GENERATED_KINDS, "blob", "named")
MASS_RANGE = (0.005, 0.4)  # kg
MESH_VERSION = 1  # bump when a generator changes: cached files are keyed by it
HOUSEHOLD_KINDS = household.CATEGORY_NAMES  # not in KINDS: the generated families' draws stay as they were
HOUSEHOLD_VERSION = 1  # bump when a household builder changes (the file names also carry a digest of its source)


def split_of(object_id: str) -> str:
    """"train" or "heldout" for an object id. Raises ValueError for a malformed id."""
    kind, index = parse_id(object_id)
    if kind == "named":
        return "heldout" if index in NAMED_HELD_OUT else "train"
    if kind in HOUSEHOLD_KINDS:
        return "heldout" if int(index) >= household.HELD_OUT_FROM else "train"
    return "heldout" if int(index) >= HELD_OUT_FROM else "train"


def parse_id(object_id: str) -> tuple[str, str]:
    """(kind, index or name) of ``kind/index``. Raises ValueError naming the known kinds and household categories."""
    kind, sep, index = str(object_id).partition("/")
    if not sep or (kind not in KINDS and kind not in HOUSEHOLD_KINDS):
        raise ValueError(f"object id {str(object_id)[:40]!r}: expected <kind>/<index>, kind one of {', '.join(KINDS)}"
                         f"; household: {' '.join(HOUSEHOLD_KINDS)}")
    if kind in HOUSEHOLD_KINDS:
        if not index.isdigit() or not 0 <= int(index) < household.INDEX_COUNT:
            raise ValueError(f"object id {object_id!r}: index must be an integer in [0, {household.INDEX_COUNT})")
    elif kind == "named":
        if index not in NAMED:
            raise ValueError(f"object id {object_id!r}: unknown named mesh; known: {', '.join(NAMED)}")
    elif not index.isdigit() or not 0 <= int(index) < INDEX_COUNT:
        raise ValueError(f"object id {object_id!r}: index must be an integer in [0, {INDEX_COUNT})")
    return kind, index


def object_ids(split: str, kinds: tuple[str, ...] = KINDS) -> dict[str, list[str]]:
    """{kind: ids of that kind in ``split``} for the requested kinds (``KINDS`` and ``HOUSEHOLD_KINDS`` names).
    Raises ValueError for an unknown split/kind."""
    if split not in SPLITS:
        raise ValueError(f"unknown split {split!r}; use one of {', '.join(SPLITS)}")
    out: dict[str, list[str]] = {}
    for kind in kinds:
        if kind not in KINDS and kind not in HOUSEHOLD_KINDS:
            raise ValueError(f"unknown object kind {kind!r}; known: {', '.join(KINDS)}; household: "
                             f"{' '.join(HOUSEHOLD_KINDS)}")
        if kind in HOUSEHOLD_KINDS:
            first, end = (household.HELD_OUT_FROM, household.INDEX_COUNT) if split == "heldout" else \
                (0, household.HELD_OUT_FROM)
            out[kind] = [f"{kind}/{i}" for i in range(first, end)]
        elif kind == "named":
            names = [n for n in NAMED if (n in NAMED_HELD_OUT) == (split == "heldout")]
            out[kind] = [f"named/{n}" for n in names]
        else:
            count = BLOB_COUNT if kind == "blob" else INDEX_COUNT
            rng = range(HELD_OUT_FROM, count) if split == "heldout" else range(HELD_OUT_FROM)
            out[kind] = [f"{kind}/{i}" for i in rng if not (kind == "blob" and i in BROKEN_BLOBS)]
    return out


def household_ids(split: str) -> dict[str, list[str]]:
    """{category: ids of that household category in ``split``}. Raises ValueError for an unknown split."""
    return object_ids(split, HOUSEHOLD_KINDS)


@lru_cache(maxsize=1)
def _household_digest() -> str:
    """8 hex digits of the household builders' source: an edited builder never reads files cached before."""
    digest = hashlib.sha1()
    for module in (household, *household.SOURCES):
        digest.update(Path(module.__file__ or "").read_bytes())
    return digest.hexdigest()[:8]


def _household_file(category: str, index: int) -> tuple[Path, HouseholdInfo]:
    """The cached visual .obj of a household object (its collision companion and .json beside it, all made on first
    use) and its info."""
    out = cache_dir("objects") / f"household-{category}-{index:02d}-v{HOUSEHOLD_VERSION}-{_household_digest()}.obj"
    meta = out.with_suffix(".json")
    collision = collision_file(out)
    if out.exists() and collision.exists() and meta.exists():
        try:
            raw = json.loads(meta.read_text())
            return out, HouseholdInfo(**{k: tuple(v) if isinstance(v, list) else v for k, v in raw["info"].items()})
        except (ValueError, KeyError, TypeError):
            pass  # unreadable or from another layout: build it again
    model = household.build(category, index)
    _write_parts(collision, [generated.inset(p) for p in model.parts])
    tmp = meta.with_name(f".{meta.name}.{os.getpid()}.tmp")
    tmp.write_text(json.dumps({"info": asdict(model.info), "params": model.params}, indent=1))
    tmp.replace(meta)
    _write_parts(out, [model.visual])
    return out, model.info


@lru_cache(maxsize=4096)
def household_info(object_id: str) -> HouseholdInfo:
    """What arrangements need of household object ``object_id`` (category, extents and pose at rest, container /
    thin, inner radius and depth, ...; see household.HouseholdInfo). Builds and caches it on first use. Raises
    ValueError for a malformed id or one of another kind."""
    kind, index = parse_id(object_id)
    if kind not in HOUSEHOLD_KINDS:
        raise ValueError(f"object id {object_id!r} is not a household object; categories: {' '.join(HOUSEHOLD_KINDS)}")
    return _household_file(kind, int(index))[1]


def _generated_file(kind: str, index: int) -> tuple[Path, float]:
    """The cached .obj of a generated object (made on first use) and its mass (kg)."""
    rng = np.random.default_rng([zlib.crc32(kind.encode()), index])
    parts, density = generated.build(kind, rng)
    mass = float(np.clip(sum(p.volume for p in parts) * density, *MASS_RANGE))
    out = cache_dir("objects") / f"{kind}-{index:03d}-v{MESH_VERSION}.obj"
    collision = collision_file(out)
    if not (out.exists() and collision.exists()):
        _write_parts(collision, [generated.inset(p) for p in parts])
        _write_parts(out, parts)
    return out, mass


def _write_parts(path: Path, parts: list[trimesh.Trimesh]) -> None:
    """Write ``parts`` as one .obj with a group per part (atomically: readers never see half a file)."""
    scene = trimesh.Scene()
    for k, part in enumerate(parts):
        scene.add_geometry(part, geom_name=f"part{k}")
    text = trimesh.exchange.obj.export_obj(scene, include_normals=False, include_texture=False,
                                           write_texture=False, include_color=False)
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    tmp.write_text(text)
    tmp.replace(path)


def _untextured(path: Path) -> Path:
    """A cached copy of a pybullet_data .obj without its material lines: textured meshes (the torus) would otherwise
    keep their texture's colours (green patches among them) whatever colour the scene gives them."""
    out = cache_dir("objects") / f"pybullet-{path.parent.name}-{path.stem}-v{MESH_VERSION}.obj"
    if not out.exists():
        lines = path.read_text(encoding="utf-8", errors="replace").splitlines(keepends=True)
        tmp = out.with_name(f".{out.name}.{os.getpid()}.tmp")
        tmp.write_text("".join(ln for ln in lines if not ln.startswith(("mtllib", "usemtl"))))
        tmp.replace(out)
    return out


@lru_cache(maxsize=256)
def _mesh_volume(path: Path) -> float:
    return mesh_volume(load_obj(path))


def object_spec(object_id: str, color: tuple[int, int, int], pose: Pose, name: str,
                target: bool = False) -> ObjectSpec:
    """An ObjectSpec (shape ``mesh``) for catalogue object ``object_id``; household objects carry their friction.
    Raises ValueError / FileNotFoundError."""
    kind, index = parse_id(object_id)
    if kind in HOUSEHOLD_KINDS:
        path, info = _household_file(kind, int(index))
        return ObjectSpec(shape="mesh", size=None, color=color, pose=pose, mesh=str(path), target=target, name=name,
                          mass=info.mass, friction=info.friction)
    if kind in GENERATED_KINDS:
        path, mass = _generated_file(kind, int(index))
        scale = (1.0, 1.0, 1.0)
    else:
        if kind == "blob":
            path, scale, density = blob_path(int(index)), (BLOB_SCALE,) * 3, 500.0
        else:
            named = NAMED[index]
            path, scale, density = data_path(named.file), named.scale, named.density
        path = _untextured(path)
        volume = _mesh_volume(path) * float(np.prod(scale))
        mass = float(np.clip(volume * density, *MASS_RANGE))
    return ObjectSpec(shape="mesh", size=None, color=color, pose=pose, mesh=str(path), target=target, name=name,
                      scale=(float(scale[0]), float(scale[1]), float(scale[2])), mass=mass)
