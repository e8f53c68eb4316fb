"""Scene files: the YAML format of DESIGN.md section 6, its dataclasses, loading and lookup by name (writing:
pg_sim.scenes.scene_writer).

```yaml
name: packed_01
target: green                 # colour name of the target the policy is asked for (default green)
family: packed                # optional; default: the folder under scenes/, else "custom"
objects:
  - shape: cube               # a shapes.REGISTRY name, or `mesh` with `mesh: path/to.obj` (relative to this file)
    size: [0.045, 0.045, 0.045]   # optional bounding-box extents (m); default from the registry; not for meshes
    scale: 1.0                # meshes only: one factor or [sx, sy, sz]
    mass: 0.08                # optional, kg; default: the shape's (meshes: from the volume)
    friction: 0.5             # optional lateral friction coefficient in (0, 2]; default: the simulator's
    color: green              # name or [r, g, b] 0-255
    pose: [x, y, z, roll, pitch, yaw]   # in `world`, metres / radians, ROS fixed-axis roll-pitch-yaw
    target: true              # optional; exactly one target. Without one, the unique object of the target colour
    name: target_cube         # optional, unique; default <shape>_<index>
```
Every problem raises ``SceneError`` (a ValueError) naming the file, the object index, the YAML line where known,
the field and its (shortened) value. Numbers may be written as YAML 1.2 reads them (``1e-3``; scene_yaml). Scenes
are held to `scene_limits.SceneLimits` (number of objects, object extents, distance from the workspace). Scene names
are paths relative to a scene folder without ``.yaml`` (``packed/case01``); the folders are ``$PG_SCENE_PATH``
(os.pathsep-separated) then the package's ``scenes/``.
"""

from __future__ import annotations

import difflib
import math
import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import yaml

from pg_core.palette import shown_name
from pg_sim.scenes.colors import PALETTE, color_name, resolve_color
from pg_sim.scenes.meshes import mesh_extents
from pg_sim.scenes.scene_limits import DEFAULT_LIMITS, SceneLimits
from pg_sim.scenes.scene_yaml import SceneLoader, check_friction
from pg_sim.scenes.shapes import REGISTRY, known_shapes
from pg_sim.scenes.short_repr import short

SCENE_PATH_ENV = "PG_SCENE_PATH"
_PKG_SCENES = (
    Path(__file__).resolve().parents[3] / "scenes",  # source / devel space: catkin_ws/src/pg_sim/scenes
    Path(__file__).resolve().parents[5] / "share" / "pg_sim" / "scenes",  # install space: lib/python3/dist-packages
)
_TOP_KEYS = {"name", "target", "family", "objects"}
_OBJECT_KEYS = {"shape", "size", "scale", "color", "pose", "target", "name", "mesh", "mass", "friction"}

Pose = tuple[float, float, float, float, float, float]
MIN_MASS, MAX_MASS = 0.001, 5.0  # kg: the masses a scene object may be given


class SceneError(ValueError):
    """A scene that cannot be found, read or validated; the message says where and what."""


@dataclass(frozen=True)
class ObjectSpec:
    """One object: shape name, bounding-box size (m, None = default), RGB 0-255, pose in `world`
    (x, y, z, roll, pitch, yaw; metres, radians, ROS fixed-axis rpy about the shape's bounding-box centre),
    absolute mesh path for shape ``mesh``, target flag, unique name, the mesh scale factors, the mass (kg, None =
    the shape's default) and the lateral friction coefficient (None = the simulator's default)."""

    shape: str
    size: tuple[float, float, float] | None
    color: tuple[int, int, int]
    pose: Pose
    mesh: str | None = None
    target: bool = False
    name: str = ""
    scale: tuple[float, float, float] = (1.0, 1.0, 1.0)
    mass: float | None = None
    friction: float | None = None


@dataclass(frozen=True)
class SceneSpec:
    """A scene: name, target colour name, objects (exactly one has target=True once parsed) and family."""

    name: str
    target: str = "green"
    objects: tuple[ObjectSpec, ...] = ()
    family: str = "custom"

    @property
    def target_index(self) -> int:
        """Index of the target object. Raises SceneError when there is not exactly one."""
        hits = [i for i, o in enumerate(self.objects) if o.target]
        if len(hits) != 1:
            raise SceneError(f"scene {self.name!r}: expected exactly one target object, found {len(hits)}")
        return hits[0]

    @property
    def target_object(self) -> ObjectSpec:
        return self.objects[self.target_index]


class _Lines:
    """YAML line numbers (1-based) of the scene's parts, from the composed node tree (None when unknown)."""

    def __init__(self, node: yaml.Node | None) -> None:
        self.root = node

    @staticmethod
    def _get(node: yaml.Node | None, key: str) -> tuple[yaml.Node | None, yaml.Node | None]:
        if isinstance(node, yaml.MappingNode):
            for k, v in node.value:
                if getattr(k, "value", None) == key:
                    return k, v
        return None, None

    def top(self, key: str) -> int | None:
        k, _ = self._get(self.root, key)
        return k.start_mark.line + 1 if k is not None else None

    def obj(self, index: int, key: str | None = None) -> int | None:
        _, seq = self._get(self.root, "objects")
        if not isinstance(seq, yaml.SequenceNode) or index >= len(seq.value):
            return None
        item = seq.value[index]
        if key is not None:
            _, v = self._get(item, key)
            item = v if v is not None else item
        return item.start_mark.line + 1


def _fail(source: str, line: int | None, what: str, index: int | None = None) -> SceneError:
    where = f"{source}:{line}" if line else source
    obj = f" object {index}:" if index is not None else ""
    return SceneError(f"{where}:{obj} {what}")


def _numbers(value: Any, count: int | tuple[int, ...], what: str) -> tuple[float, ...]:
    counts = (count,) if isinstance(count, int) else count
    if not isinstance(value, list | tuple) or len(value) not in counts:
        n = len(value) if isinstance(value, list | tuple) else type(value).__name__
        raise ValueError(f"{what} must be a list of {' or '.join(map(str, counts))} numbers, got {n}: {short(value)}")
    if not all(isinstance(v, int | float) and not isinstance(v, bool) and math.isfinite(v) for v in value):
        raise ValueError(f"{what} must contain finite numbers only, got {short(value)}")
    return tuple(float(v) for v in value)


def _parse_object(raw: Any, i: int, source: str, base_dir: Path, lines: _Lines, limits: SceneLimits,
                  mesh_folders: Sequence[Path] | None) -> ObjectSpec:
    def fail(what: str, key: str | None = None) -> SceneError:
        return _fail(source, lines.obj(i, key), what, i)

    if not isinstance(raw, Mapping):
        raise fail(f"must be a mapping with shape, color and pose, got {type(raw).__name__}")
    unknown = set(raw) - _OBJECT_KEYS
    if unknown:
        key = str(next(iter(unknown)))
        raise fail(f"unknown key(s) {short(sorted(map(str, unknown)))}; allowed: {sorted(_OBJECT_KEYS)}", key)
    for key in ("shape", "color", "pose"):
        if key not in raw:
            raise fail(f"missing required key {key!r}")
    shape = raw["shape"]
    if not isinstance(shape, str) or shape not in known_shapes():
        raise fail(f"unknown shape {short(shape)}; known shapes: {', '.join(known_shapes())}", "shape")
    try:
        color = resolve_color(raw["color"])
    except ValueError as e:
        raise fail(str(e), "color") from None
    try:
        pose = _numbers(raw["pose"], 6, "pose [x, y, z, roll, pitch, yaw]")
        limits.check_position(pose[:3])
    except ValueError as e:
        raise fail(str(e), "pose") from None
    size = None
    scale = (1.0, 1.0, 1.0)
    mesh = None
    try:
        if shape == "mesh":
            if "size" in raw:
                raise ValueError("mesh objects take `scale`, not `size`")
            if "scale" in raw:
                sc = raw["scale"]
                vals = _numbers([sc] * 3 if isinstance(sc, int | float) else sc, 3, "scale")
                if min(vals) <= 0:
                    raise ValueError(f"scale must be positive, got {short(sc)}")
                scale = (vals[0], vals[1], vals[2])
        elif "scale" in raw:
            raise ValueError("`scale` is for mesh objects only; use `size`")
        elif raw.get("size") is not None:
            size = tuple(REGISTRY[shape].resolve_size(_numbers(raw["size"], 3, "size [x, y, z]")))
            limits.check_extents(size, "size")
    except ValueError as e:
        raise fail(str(e), "size" if "size" in raw else "scale") from None
    if shape == "mesh":
        if not isinstance(raw.get("mesh"), str) or not raw["mesh"]:
            raise fail("shape `mesh` needs `mesh: path/to/file.obj`")
        path = Path(os.path.expanduser(raw["mesh"]))
        path = (path if path.is_absolute() else base_dir / path).resolve()
        if mesh_folders is not None and not any(path.is_relative_to(d) for d in mesh_folders):
            raise fail(f"mesh {short(raw['mesh'], 160)} ({short(str(path), 160)}) is outside the allowed mesh folders "
                       f"{short([str(d) for d in mesh_folders], 160)}", "mesh")
        if not path.is_file():
            raise fail(f"mesh file not found: {path}", "mesh")
        try:
            extents = mesh_extents(path, scale)
        except (ValueError, OSError) as e:
            raise fail(str(e), "mesh") from None
        try:
            limits.check_extents(extents, "mesh extents (scaled)")
        except ValueError as e:
            raise fail(str(e), "scale" if "scale" in raw else "mesh") from None
        mesh = str(path)
    elif "mesh" in raw:
        raise fail(f"`mesh` is only valid with shape `mesh`, not {shape!r}", "mesh")
    target = raw.get("target", False)
    if not isinstance(target, bool):
        raise fail(f"target must be true or false, got {short(target)}", "target")
    name = raw.get("name", f"{shape}_{i}")
    if not isinstance(name, str) or not name:
        raise fail(f"name must be a non-empty string, got {short(name)}", "name")
    mass = raw.get("mass")
    if mass is not None and (isinstance(mass, bool) or not isinstance(mass, int | float)
                             or not MIN_MASS <= mass <= MAX_MASS):
        raise fail(f"mass must be a number of kg in [{MIN_MASS}, {MAX_MASS}], got {short(mass)}", "mass")
    try:
        friction = None if raw.get("friction") is None else check_friction(raw["friction"])
    except ValueError as e:
        raise fail(f"{short(name)}: {e}", "friction") from None
    return ObjectSpec(shape, size, color, pose, mesh, target, name, scale,  # type: ignore[arg-type]
                      None if mass is None else float(mass), friction)


def parse_scene(
    mapping: Any, source: str = "<scene>", base_dir: str | Path | None = None, node: yaml.Node | None = None,
    limits: SceneLimits = DEFAULT_LIMITS, mesh_folders: Sequence[str | os.PathLike[str]] | None = None,
) -> SceneSpec:
    """Validate a scene mapping (as read from YAML) into a SceneSpec whose target object is marked.

    ``source`` names the origin in messages, ``base_dir`` resolves relative mesh paths (default: the folder of
    ``source`` if it is a file, else the working directory), ``node`` (from yaml.compose) supplies line numbers.
    ``limits`` bound the objects; ``mesh_folders`` (None: anywhere) are the folders mesh files may lie in, checked
    before a mesh file is touched. Raises SceneError.
    """
    lines = _Lines(node)
    src_path = Path(source)
    base = Path(base_dir) if base_dir is not None else (src_path.parent if src_path.is_file() else Path.cwd())
    if not isinstance(mapping, Mapping):
        raise _fail(source, 1, f"a scene must be a mapping with name, target and objects, got {type(mapping).__name__}")
    unknown = set(mapping) - _TOP_KEYS
    if unknown:
        key = str(next(iter(unknown)))
        raise _fail(source, lines.top(key),
                    f"unknown key(s) {short(sorted(map(str, unknown)))}; allowed: {sorted(_TOP_KEYS)}")
    name = mapping.get("name", src_path.stem)
    target = mapping.get("target", "green")
    if not isinstance(target, str) or target.strip().lower().replace("grey", "gray") not in PALETTE:
        raise _fail(source, lines.top("target"),
                    f"unknown target colour {shown_name(target)}; known: {', '.join(PALETTE)}")
    target = target.strip().lower().replace("grey", "gray")
    family = mapping.get("family") or _family_of(src_path)
    objs = mapping.get("objects")
    if not isinstance(objs, list) or not objs:
        raise _fail(source, lines.top("objects"), "`objects` must be a non-empty list")
    try:
        limits.check_count(len(objs))
    except ValueError as e:
        raise _fail(source, lines.top("objects"), str(e)) from None
    folders = None if mesh_folders is None else tuple(Path(d).resolve() for d in mesh_folders)
    specs = [_parse_object(raw, i, source, base, lines, limits, folders) for i, raw in enumerate(objs)]
    seen: dict[str, int] = {}
    for i, o in enumerate(specs):
        if o.name in seen:
            raise _fail(source, lines.obj(i, "name"), f"duplicate name {short(o.name)} (also object {seen[o.name]})", i)
        seen[o.name] = i
    flagged = [i for i, o in enumerate(specs) if o.target]
    if len(flagged) == 1:
        _refuse_shared_target_colour(specs, flagged[0], source, lines)
    if len(flagged) > 1:
        raise _fail(source, lines.obj(flagged[1], "target"), f"several targets: objects {flagged}; exactly one allowed")
    if not flagged:
        rgb = PALETTE[target]
        flagged = [i for i, o in enumerate(specs) if o.color == rgb]
        if len(flagged) != 1:
            raise _fail(
                source, lines.top("objects"),
                f"no object has `target: true` and {len(flagged)} objects (need exactly one) have the target colour "
                f"{target} {rgb}" + (f": objects {flagged}" if flagged else ""),
            )
        specs[flagged[0]] = replace(specs[flagged[0]], target=True)
    return SceneSpec(str(name), target, tuple(specs), str(family))


def _refuse_shared_target_colour(specs: list[ObjectSpec], target: int, source: str, lines: _Lines) -> None:
    """Raise SceneError naming both objects when another object has the target object's colour: the goal would be
    ambiguous to every policy (they are told a colour, not an object)."""
    rgb = specs[target].color
    for i, o in enumerate(specs):
        if i != target and o.color == rgb:
            raise _fail(source, lines.obj(i, "color"),
                        f"object {i} ({short(o.name)}) has the colour {color_name(rgb) or list(rgb)} of the target, "
                        f"object {target} ({short(specs[target].name)}): the goal would be ambiguous; give it another "
                        "colour", i)


def _family_of(path: Path) -> str:
    for d in scene_dirs():
        try:
            rel = path.resolve().relative_to(d.resolve())
        except ValueError:
            continue
        if len(rel.parts) > 1:
            return rel.parts[0]
    return "custom"


def load_scene(path_or_name: str | os.PathLike[str], limits: SceneLimits = DEFAULT_LIMITS,
               mesh_folders: Sequence[str | os.PathLike[str]] | None = None) -> SceneSpec:
    """Read and validate a scene file (a path, or a scene name such as ``packed/case01``) within ``limits``, its
    meshes in ``mesh_folders`` (None: anywhere). Raises SceneError."""
    path = find_scene(path_or_name)
    try:
        text = path.read_text(encoding="utf-8")
    except OSError as e:
        raise SceneError(f"{path}: cannot read scene file: {e}") from None
    except UnicodeDecodeError as e:
        raise SceneError(f"{path}: not a UTF-8 text file (byte {e.start}): a scene is a YAML text file") from None
    loader = SceneLoader(text)
    try:
        node = loader.get_single_node()
        data = loader.construct_document(node) if node is not None else None
    except yaml.YAMLError as e:
        mark = getattr(e, "problem_mark", None)
        line = mark.line + 1 if mark is not None else None
        raise _fail(str(path), line, f"YAML syntax error: {getattr(e, 'problem', None) or e}") from None
    finally:
        loader.dispose()
    return parse_scene(data, str(path), path.parent, node, limits, mesh_folders)


def scene_dirs() -> list[Path]:
    """Folders searched for scene names: ``$PG_SCENE_PATH`` entries, then the package's scenes/ (existing only)."""
    extra = [Path(d) for d in os.environ.get(SCENE_PATH_ENV, "").split(os.pathsep) if d]
    return [d for d in (*extra, *_PKG_SCENES) if d.is_dir()]


def list_scenes() -> list[str]:
    """Names of all scenes in ``scene_dirs()`` (e.g. ``packed/case01``), sorted, without duplicates."""
    names = {
        f.relative_to(d).with_suffix("").as_posix() for d in scene_dirs() for f in d.rglob("*.yaml") if f.is_file()
    }
    return sorted(names)


def find_scene(name_or_path: str | os.PathLike[str]) -> Path:
    """Path of a scene given as a file path or as a name relative to a scene folder (``.yaml`` optional).

    Raises SceneError naming close matches when nothing is found.
    """
    text = os.fspath(name_or_path)
    path = Path(os.path.expanduser(text))
    if path.is_file():
        return path.resolve()
    name = text[:-5] if text.endswith(".yaml") else text
    for d in scene_dirs():
        cand = d / f"{name}.yaml"
        if cand.is_file():
            return cand.resolve()
    known = list_scenes()
    close = difflib.get_close_matches(name, known, n=5, cutoff=0.5)
    hint = f"; did you mean: {', '.join(close)}?" if close else (f"; known scenes: {', '.join(known)}" if known else "")
    raise SceneError(f"scene {short(text, 160)} not found as a file or in {[str(d) for d in scene_dirs()]}{hint}")
