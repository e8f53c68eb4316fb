"""Import the VPG / Xu et al. / [K] text test cases (``mesh_file r g b x y z alpha beta gamma`` per line) as scenes.

Colour components are 0-1 floats (stored as round(255 c)), positions metres, angles radians; row 0 is the target.
Block meshes map to our shapes (``concave.obj`` -> arch ...), household names (milk, cup, ...) to the household shapes,
any other name (VPG's numbered meshes ``0.obj``...) to shape ``mesh`` with the file found in ``mesh_dir``.

Frames. The files come in two frames (detected from the mean x, see ``GAZEBO_MIN_X``, or forced with ``frame``):
- ``coppeliasim`` (VPG, the paper's case 2-6; x in [-0.724, -0.276]): the angles are CoppeliaSim's Euler angles,
  R = Rx(alpha) Ry(beta) Rz(gamma) (elemental rotations about the absolute Z, then Y, then X axes; CoppeliaSim manual,
  "Euler angles"), applied to the meshes in their .obj frame, which is our shapes' frame.
- ``gazebo`` (case 1, 7-9, 11-14; x ~ 0.5-0.75): Gazebo world poses with x and y swapped with respect to the
  authors' ``gazebo_world.sdf`` (which is the consistent scene: swapping x/y alone mirrors positions but not
  orientations). We swap them back, read the angles as SDF roll-pitch-yaw (fixed axes x, y, z: R = Rz Ry Rx) of the
  authors' Gazebo models, whose frames differ from the .obj frames: ``GAZEBO_MODEL_FRAMES`` (inferred by matching the
  SDF copies of case 2-6 against the CoppeliaSim files) maps our shape frame to theirs; then the scene is turned by
  -90 deg about z so that it has the orientation of the CoppeliaSim files.
Household meshes were never published: our household shapes keep the file's position and yaw and rest in their
own natural pose. Finally the scene is centred on `world` (the xy centre of the bounding box of the positions is
subtracted, which also removes the +0.1 m y offset of [K]); z is kept but raised where the object would cut the table.
"""

from __future__ import annotations

import argparse
import math
import os
import sys
from collections.abc import Sequence
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

from pg_sim.scenes.colors import color_name, nearest_color_name, resolve_color
from pg_sim.scenes.meshes import mesh_extents
from pg_sim.scenes.scene import ObjectSpec, SceneError, SceneSpec, save_scene
from pg_sim.scenes.shapes import REGISTRY

BLOCK_MESHES: dict[str, str] = {
    "cube": "cube",
    "rect": "rect",
    "triangle": "triangle",
    "concave": "arch",
    "cylinder": "cylinder",
    "half-cube": "half_cube",
    "half-cylinder": "half_cylinder",
}
HOUSEHOLD_MESHES: dict[str, str] = {
    "milk": "milk_box", "milk_box": "milk_box",
    "cup": "mug", "mug": "mug", "cappuccino": "mug",
    "soap": "soap", "cheese": "soap", "camembert": "soap",
    "glue": "glue",
    "toothpaste": "small_box", "colgate": "small_box", "sweetener": "small_box", "biscuit": "small_box",
    "carrs": "small_box", "gum": "small_box", "chewinggum": "small_box", "tea": "small_box", "teagreen": "small_box",
    "sugar": "small_box", "rice": "small_box",
    "cos": "bottle", "shampoo": "bottle", "cleaner": "bottle", "bottle": "bottle",
    "oilcan": "can", "tuna": "can", "salt": "can", "coke": "can", "coke_can": "can", "can": "can",
}
_RX90 = Rotation.from_euler("x", 90, degrees=True)
# Rotation from our shape frame to the frame of the authors' Gazebo model of the same block (see module docstring).
GAZEBO_MODEL_FRAMES: dict[str, Rotation] = {
    "cube": _RX90.inv(),
    "rect": _RX90.inv(),
    "arch": _RX90.inv(),
    "half_cube": _RX90.inv(),
    "half_cylinder": _RX90.inv(),
    "triangle": _RX90.inv() * Rotation.from_euler("z", 90, degrees=True),
    "cylinder": Rotation.identity(),
}
GAZEBO_MIN_X = 0.25  # m: files whose mean x exceeds this are in the Gazebo frame (x ~ 0.5-0.75), else CoppeliaSim
FIELDS = ("mesh", "r", "g", "b", "x", "y", "z", "alpha", "beta", "gamma")
FRAMES = ("auto", "coppeliasim", "gazebo")


def shape_for_mesh(mesh_file: str) -> str | None:
    """Our shape name for a mesh file name of the case files, or None for an unknown (e.g. numbered) mesh."""
    stem = Path(mesh_file).stem.lower()
    if stem in BLOCK_MESHES:
        return BLOCK_MESHES[stem]
    for key in (stem, stem.removeprefix("z_").rstrip("0123456789").rstrip("_-")):
        if key in HOUSEHOLD_MESHES:
            return HOUSEHOLD_MESHES[key]
    return None


def _parse_rows(path: Path) -> list[tuple[int, str, list[float]]]:
    rows = []
    for lineno, line in enumerate(path.read_text(encoding="utf-8", errors="replace").splitlines(), 1):
        tok = line.split()
        if not tok or tok[0].startswith("#"):
            continue
        if len(tok) != len(FIELDS):
            raise SceneError(
                f"{path}:{lineno}: expected {len(FIELDS)} fields ({' '.join(FIELDS)}), got {len(tok)}: {line.strip()!r}"
            )
        vals = []
        for name, t in zip(FIELDS[1:], tok[1:], strict=True):
            try:
                v = float(t)
            except ValueError:
                raise SceneError(f"{path}:{lineno}: field {name!r} is not a number: {t!r}") from None
            if not math.isfinite(v):
                raise SceneError(f"{path}:{lineno}: field {name!r} is not finite: {t!r}")
            vals.append(v)
        if not all(0.0 <= c <= 1.0 for c in vals[:3]):
            raise SceneError(f"{path}:{lineno}: colour components must lie in 0-1, got {vals[:3]}")
        rows.append((lineno, tok[0], vals))
    if not rows:
        raise SceneError(f"{path}: no objects (expected lines `{' '.join(FIELDS)}`)")
    return rows


def _orientation(shape: str, frame: str, angles: Sequence[float]) -> Rotation:
    """World rotation of our shape (before the household yaw-only rule) for the file's angles."""
    a, b, g = angles
    if frame == "coppeliasim":
        return Rotation.from_euler("XYZ", [a, b, g])  # intrinsic x-y'-z'' = R = Rx(a) Ry(b) Rz(g)
    model = GAZEBO_MODEL_FRAMES.get(shape, Rotation.identity())
    return Rotation.from_euler("z", -90, degrees=True) * Rotation.from_euler("xyz", [a, b, g]) * model


def _household_rotation(shape: str, rot: Rotation) -> Rotation:
    """Yaw-only rotation of a household shape in its own rest pose for the file's rotation of the authors' model.

    Their models are assumed upright with z as the long axis: when that axis lies (roll about 90 deg), our shape's
    longer horizontal axis is laid along it; otherwise the model's x heading is kept.
    """
    m = rot.as_matrix()
    if abs(m[2, 2]) > math.sqrt(0.5):
        return Rotation.from_euler("z", math.atan2(m[1, 0], m[0, 0]))
    ext = REGISTRY[shape].extents()
    heading = math.atan2(m[1, 2], m[0, 2]) - (0.0 if ext[0] >= ext[1] else math.pi / 2)
    return Rotation.from_euler("z", math.atan2(math.sin(heading), math.cos(heading)))


def import_vpg(
    path: str | os.PathLike[str],
    mesh_dir: str | os.PathLike[str] | None = None,
    name: str | None = None,
    *,
    frame: str = "auto",
    target_color: str | None = None,
    family: str | None = None,
) -> SceneSpec:
    """Read a text test case into a SceneSpec centred on `world` (see the module docstring for frames).

    ``mesh_dir``: folder of meshes that are not one of our shapes; ``name``: scene name (default the file stem);
    ``frame``: auto | coppeliasim | gazebo; ``target_color``: recolour the target (row 0) with this palette colour
    (e.g. green for the household scenes, whose milk box is white in the files); ``family``: default "household"
    when a household shape occurs, else "packed". The scene's target colour name is ``target_color``, else the
    palette name of row 0's colour, else the nearest palette name. Raises SceneError naming the line for a
    malformed file or a mesh that cannot be found.
    """
    src = Path(path)
    if not src.is_file():
        raise SceneError(f"{src}: test-case file not found")
    if frame not in FRAMES:
        raise SceneError(f"unknown frame {frame!r}; use one of {', '.join(FRAMES)}")
    if target_color is not None:
        target_color = resolve_target_name(target_color)
    rows = _parse_rows(src)
    if frame == "auto":
        frame = "gazebo" if np.mean([v[3] for _, _, v in rows]) > GAZEBO_MIN_X else "coppeliasim"
    objects: list[ObjectSpec] = []
    positions = []
    for index, (lineno, mesh_file, vals) in enumerate(rows):
        shape = shape_for_mesh(mesh_file)
        mesh = None
        if shape is None:
            if mesh_dir is None:
                raise SceneError(f"{src}:{lineno}: mesh {mesh_file!r} is not one of our shapes; pass a mesh directory")
            mesh_path = Path(mesh_dir) / mesh_file
            if not mesh_path.is_file():
                raise SceneError(f"{src}:{lineno}: mesh {mesh_file!r} not found in {mesh_dir}")
            shape, mesh = "mesh", str(mesh_path.resolve())
        rot = _orientation(shape, frame, vals[6:9])
        if shape in REGISTRY and REGISTRY[shape].household:
            rot = _household_rotation(shape, rot)
        x, y, z = vals[3:6]
        if frame == "gazebo":
            y = -y  # swap back to the SDF frame (x', y') = (y, x), then turn by -90 deg: (y', -x') = (x, -y)
        ext = np.asarray(mesh_extents(mesh) if mesh else REGISTRY[shape].extents())
        half_height = 0.5 * float(np.abs(rot.as_matrix())[2] @ ext)
        z = max(z, half_height + 1e-4)
        rgb = tuple(int(round(255 * c)) for c in vals[:3])
        if index == 0 and target_color is not None:
            rgb = resolve_color(target_color)
        rpy = rot.as_euler("xyz")  # fixed-axis roll, pitch, yaw (ROS)
        pose = (x, y, z, *(float(v) for v in rpy))
        objects.append(ObjectSpec(shape, None, rgb, pose, mesh, index == 0, f"{shape}_{index}"))  # type: ignore[arg-type]
        positions.append((x, y))
    pos = np.asarray(positions)
    centre = (pos.min(axis=0) + pos.max(axis=0)) / 2.0
    centred = []
    for o in objects:
        x, y, z, r, pi, yw = o.pose
        pose = tuple(round(float(v), 6) for v in (x - centre[0], y - centre[1], z, r, pi, yw))
        centred.append(ObjectSpec(o.shape, o.size, o.color, pose, o.mesh, o.target, o.name))
    target = target_color or color_name(objects[0].color) or nearest_color_name(objects[0].color)
    household = any(o.shape in REGISTRY and REGISTRY[o.shape].household for o in objects)
    fam = family or ("household" if household else "packed")
    return SceneSpec(name or src.stem, resolve_target_name(target), tuple(centred), fam)


def resolve_target_name(name: str) -> str:
    """Normalise a palette colour name (raises SceneError for an unknown one)."""
    try:
        resolve_color(name)
    except ValueError as e:
        raise SceneError(str(e)) from None
    return name.strip().lower().replace("grey", "gray")


def main(argv: Sequence[str] | None = None) -> int:
    """``python -m pg_sim.scenes.vpg_import FILE --out YAML [--mesh-dir DIR] [--name NAME] [--frame F]
    [--target-color C]``."""
    ap = argparse.ArgumentParser(prog="python -m pg_sim.scenes.vpg_import", description=__doc__.split("\n\n")[0])
    ap.add_argument("file", type=Path, help="text case: one `mesh r g b x y z alpha beta gamma` line per object")
    ap.add_argument("--mesh-dir", type=Path, default=None, help="folder of the meshes that are not our shapes")
    ap.add_argument("--out", type=Path, required=True, help="scene YAML to write")
    ap.add_argument("--name", default=None, help="scene name (default: the file's stem)")
    ap.add_argument("--frame", choices=FRAMES, default="auto", help="frame of the file (default: detect)")
    ap.add_argument("--target-color", default=None, help="recolour the target (row 0), e.g. green")
    ap.add_argument("--family", default=None, help="scene family (default: household or packed)")
    args = ap.parse_args(argv)
    try:
        scene = import_vpg(args.file, args.mesh_dir, args.name, frame=args.frame, target_color=args.target_color,
                           family=args.family)
        save_scene(scene, args.out)
    except (SceneError, OSError, ValueError) as e:
        print(f"error: {e}", file=sys.stderr)
        return 1
    print(f"wrote {args.out}: {len(scene.objects)} objects, target {scene.target} ({scene.target_object.shape})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
