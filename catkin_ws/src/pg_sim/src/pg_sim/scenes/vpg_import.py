"""Import the VPG / Xu / [K] text test cases (``mesh_file r g b x y z alpha beta gamma`` per line) as scenes.

Colour components are 0-1 floats (stored as round(255 c)), positions metres, angles radians. Block meshes map to our
shapes (``concave.obj`` -> arch ...), household names (milk, cup, ...) to the household shapes, any other name (VPG's
numbered meshes ``0.obj``...) to shape ``mesh`` with the file found in ``mesh_dir``. Household meshes were never
published: our household shapes keep the file's position and yaw and rest in their own natural pose. z is kept but
raised where the object would cut the table.

Frames and workspaces: ``pg_sim.scenes.vpg_frames`` (coppeliasim / gazebo frames; the ``vpg``, ``xu`` and ``gazebo``
source workspaces). The source's workspace centre is mapped onto `world` (``centre="workspace"``, the default), so
each object keeps its position relative to the workspace of the simulator that wrote the file. The source is
``auto`` by default (``vpg`` or ``gazebo`` by the rows, see ``resolve_source``); Xu et al.'s files need
``--source xu`` (their loader adds +0.1 m to y). ``--workspace-centre X Y`` gives any other centre (file coordinates).
Rows outside the source workspace widened by ``margin`` (0.05 m; x, y and z in [0, 0.4]) are where the source parks
unused objects (x < -0.85, |y| > 0.4, z = -726 in VPG's test-10-obj-00): they are left out, BEFORE their mesh is
looked up, and reported (``ImportResult.skipped``; ``import_vpg`` warns; the CLI prints them). A parked target row is
an error naming the line.

Target: row ``target_row`` (0-based among the file's object rows, i.e. its non-blank, non-comment lines; default 0;
Xu et al.'s README lists the goal row of each case). If another imported object has exactly the target's colour (or
the palette colour the target is named by) the goal is ambiguous: SceneError naming both rows, unless
``target_color`` recolours the target to a colour no other object has.

``centre="rows"`` (CLI ``--centre rows``) keeps the old behaviour: the scene is centred on the xy centre of the
bounding box of the imported rows; for files without parked rows (all of the paper authors' case files) this is the old
importer's output exactly. The reference-case tests (pg_sim/test/test_vpg_import.py) use it where they compare
poses relative to the rows (Gazebo copy vs CoppeliaSim file) and check that both modes give the same scene up to a
translation. The shipped scenes under scenes/{packed,household} are left as they are: they are not this importer's
output (their shapes and poses differ from the case files) and nothing here regenerates or compares them.
"""

from __future__ import annotations

import argparse
import math
import os
import sys
import warnings
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from pg_sim.scenes.colors import PALETTE, color_name, nearest_color_name, resolve_color
from pg_sim.scenes.meshes import mesh_extents
from pg_sim.scenes.scene import ObjectSpec, SceneError, SceneSpec
from pg_sim.scenes.scene_writer import save_scene
from pg_sim.scenes.shapes import REGISTRY
from pg_sim.scenes.vpg_frames import (
    DEFAULT_MARGIN,
    FRAMES,
    SOURCE_CHOICES,
    SourceWorkspace,
    frame_xy,
    household_rotation,
    orientation,
    resolve_source,
)

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
FIELDS = ("mesh", "r", "g", "b", "x", "y", "z", "alpha", "beta", "gamma")
CENTRES = ("workspace", "rows")


@dataclass(frozen=True)
class SkippedRow:
    """A row left out: its file line, 0-based row index, mesh name, file position and the reason."""

    line: int
    row: int
    mesh: str
    position: tuple[float, float, float]
    reason: str

    def __str__(self) -> str:
        x, y, z = self.position
        return f"line {self.line} (row {self.row}, {self.mesh}) at ({x:.3f}, {y:.3f}, {z:.3f}): {self.reason}"


@dataclass(frozen=True)
class ImportResult:
    """The imported scene, the rows left out, the source workspace used and the file's target row (0-based)."""

    scene: SceneSpec
    skipped: tuple[SkippedRow, ...]
    workspace: SourceWorkspace
    target_row: int


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


def _check_args(centre: str, margin: float, target_row: int) -> None:
    if centre not in CENTRES:
        raise SceneError(f"unknown centre {centre!r}; use one of {', '.join(CENTRES)}")
    if isinstance(margin, bool) or not isinstance(margin, int | float) or not math.isfinite(margin) or margin < 0:
        raise SceneError(f"margin must be a finite number of metres >= 0, got {margin!r}")
    if isinstance(target_row, bool) or not isinstance(target_row, int | np.integer):
        raise SceneError(f"target row must be an integer row index, got {target_row!r}")


def _refuse_ambiguous_target(src: Path, objects: list[tuple[int, int, str, ObjectSpec]], target: str,
                             recoloured: bool) -> None:
    """SceneError naming both rows when another object has the target's colour or the colour it is named by."""
    t_line, t_row, t_mesh, t_obj = next(o for o in objects if o[3].target)
    for line, row, mesh, o in objects:
        if o.target or o.color not in (t_obj.color, PALETTE[target]):
            continue
        how = ("choose a target colour no other object has" if recoloured
               else "pass --target-color (target_color) with a colour no other object has")
        colour = color_name(o.color) or list(o.color)
        same = f"the same colour {colour} as" if o.color == t_obj.color else f"the colour {colour} that names"
        raise SceneError(f"{src}:{line}: row {row} ({mesh}) has {same} the target, row {t_row} ({t_mesh}, line "
                         f"{t_line}): the goal would be ambiguous; {how}")


def import_case(
    path: str | os.PathLike[str],
    mesh_dir: str | os.PathLike[str] | None = None,
    name: str | None = None,
    *,
    source: str = "auto",
    frame: str = "auto",
    workspace_centre: Sequence[float] | None = None,
    centre: str = "workspace",
    margin: float = DEFAULT_MARGIN,
    target_row: int = 0,
    target_color: str | None = None,
    family: str | None = None,
) -> ImportResult:
    """Read a text test case into an ImportResult (scene, rows left out, source workspace; see the module docstring).

    ``mesh_dir``: folder of meshes that are not one of our shapes; ``name``: scene name (default the file stem);
    ``source``: auto | vpg | xu | gazebo; ``frame``: auto | coppeliasim | gazebo; ``workspace_centre``: (X, Y) in the
    file's coordinates instead of the source's; ``centre``: workspace (map the source workspace onto `world`) | rows
    (centre the bounding box of the imported rows, the old behaviour); ``margin``: metres beyond the source workspace
    a row may lie; ``target_row``: 0-based object row of the target; ``target_color``: recolour the target with this
    palette colour (e.g. green for the household scenes, whose milk box is white in the files); ``family``: default
    "household" when a household shape occurs, else "packed". The scene's target colour name is ``target_color``,
    else the palette name of the target's colour, else the nearest palette name. Raises SceneError naming the line
    for a malformed file, a parked target, a mesh that cannot be found or a target colour another object shares.
    """
    src = Path(path)
    if not src.is_file():
        raise SceneError(f"{src}: test-case file not found")
    _check_args(centre, margin, target_row)
    if target_color is not None:
        target_color = resolve_target_name(target_color)
    rows = _parse_rows(src)
    if not 0 <= target_row < len(rows):
        raise SceneError(f"{src}: target row {target_row} out of range: the file has {len(rows)} object rows "
                         f"(0-based rows 0-{len(rows) - 1})")
    workspace = resolve_source([v[3:6] for _, _, v in rows], source, frame, workspace_centre, margin)
    frame = workspace.frame
    kept: list[tuple[int, int, str, ObjectSpec]] = []
    skipped: list[SkippedRow] = []
    for index, (lineno, mesh_file, vals) in enumerate(rows):
        why = workspace.outside(vals[3:6], margin)
        if why is not None:
            if index == target_row:
                raise SceneError(f"{src}:{lineno}: the target (row {index}, {mesh_file}) is parked {why}")
            skipped.append(SkippedRow(lineno, index, mesh_file, (vals[3], vals[4], vals[5]), why))
            continue
        shape = shape_for_mesh(mesh_file)
        mesh = None
        if shape is None:
            if mesh_dir is None:
                raise SceneError(f"{src}:{lineno}: mesh {mesh_file!r} is not one of our shapes; pass a mesh directory")
            mesh_path = Path(mesh_dir) / mesh_file
            if not mesh_path.is_file():
                raise SceneError(f"{src}:{lineno}: mesh {mesh_file!r} not found in {mesh_dir}")
            shape, mesh = "mesh", str(mesh_path.resolve())
        rot = orientation(shape, frame, vals[6:9])
        if shape in REGISTRY and REGISTRY[shape].household:
            rot = household_rotation(shape, rot)
        x, y = frame_xy(frame, vals[3], vals[4])
        ext = np.asarray(mesh_extents(mesh) if mesh else REGISTRY[shape].extents())
        half_height = 0.5 * float(np.abs(rot.as_matrix())[2] @ ext)
        z = max(vals[5], half_height + 1e-4)
        rgb = tuple(int(round(255 * c)) for c in vals[:3])
        if index == target_row and target_color is not None:
            rgb = resolve_color(target_color)
        pose = (x, y, z, *(float(v) for v in rot.as_euler("xyz")))  # fixed-axis roll, pitch, yaw (ROS)
        obj = ObjectSpec(shape, None, rgb, pose, mesh, index == target_row, f"{shape}_{index}")  # type: ignore[arg-type]
        kept.append((lineno, index, mesh_file, obj))
    if centre == "rows":
        pos = np.asarray([o.pose[:2] for *_, o in kept])
        offset = (pos.min(axis=0) + pos.max(axis=0)) / 2.0
    else:
        offset = np.asarray(frame_xy(frame, *workspace.centre))
    objects = []
    for lineno, index, mesh_file, o in kept:
        x, y, z, r, pi, yw = o.pose
        pose = tuple(round(float(v), 6) for v in (x - offset[0], y - offset[1], z, r, pi, yw))
        objects.append((lineno, index, mesh_file, ObjectSpec(o.shape, o.size, o.color, pose, o.mesh, o.target, o.name)))
    target_obj = next(o for *_, o in objects if o.target)
    target = resolve_target_name(target_color or color_name(target_obj.color) or nearest_color_name(target_obj.color))
    _refuse_ambiguous_target(src, objects, target, target_color is not None)
    household = any(o.shape in REGISTRY and REGISTRY[o.shape].household for *_, o in objects)
    fam = family or ("household" if household else "packed")
    scene = SceneSpec(name or src.stem, target, tuple(o for *_, o in objects), fam)
    return ImportResult(scene, tuple(skipped), workspace, target_row)


def import_vpg(path: str | os.PathLike[str], mesh_dir: str | os.PathLike[str] | None = None,
               name: str | None = None, **options: Any) -> SceneSpec:
    """``import_case(...).scene`` (same arguments), with a UserWarning listing the rows left out, if any."""
    result = import_case(path, mesh_dir, name, **options)
    if result.skipped:
        warnings.warn(f"{path}: left out {len(result.skipped)} row(s) outside the {result.workspace.describe()}: "
                      + "; ".join(map(str, result.skipped)), UserWarning, stacklevel=2)
    return result.scene


def resolve_target_name(name: str) -> str:
    """Normalise a palette colour name (raises SceneError for an unknown one)."""
    try:
        resolve_color(name)
    except ValueError as e:
        raise SceneError(str(e)) from None
    return name.strip().lower().replace("grey", "gray")


def add_arguments(ap: argparse.ArgumentParser) -> None:
    """The importer's command-line arguments (shared by ``python -m`` and ``pushgrasp scene import-vpg``)."""
    ap.add_argument("file", type=Path, help="text case: one `mesh r g b x y z alpha beta gamma` line per object")
    ap.add_argument("--mesh-dir", type=Path, default=None, help="folder of the meshes that are not our shapes")
    ap.add_argument("--out", type=Path, required=True, help="scene YAML to write")
    ap.add_argument("--name", default=None, help="scene name (default: the file's stem)")
    ap.add_argument("--source", choices=SOURCE_CHOICES, default="auto",
                    help="simulator whose workspace the file uses: vpg (centre -0.5 0), xu (Xu et al. / [K], whose "
                         "loader adds +0.1 m to y: centre -0.5 -0.1), gazebo (centre 0.655 0.007); default auto: "
                         "vpg or gazebo, by the rows that lie in either")
    ap.add_argument("--frame", choices=FRAMES, default="auto", help="frame of the file (default: from the source)")
    ap.add_argument("--workspace-centre", "--workspace-center", nargs=2, type=float, metavar=("X", "Y"),
                    default=None, help="centre of the source workspace in the file's coordinates (overrides --source)")
    ap.add_argument("--centre", "--center", choices=CENTRES, default="workspace",
                    help="workspace: map the source workspace centre onto `world` (default); rows: centre the "
                         "bounding box of the imported rows (the old behaviour)")
    ap.add_argument("--margin", type=float, default=DEFAULT_MARGIN,
                    help=f"metres beyond the source workspace a row may lie before it is left out "
                         f"(default {DEFAULT_MARGIN})")
    ap.add_argument("--target-row", type=int, default=0,
                    help="0-based index of the target among the file's object rows (default 0)")
    ap.add_argument("--target-color", default=None, help="recolour the target, e.g. green")
    ap.add_argument("--family", default=None, help="scene family (default: household or packed)")


def main(argv: Sequence[str] | None = None) -> int:
    """``python -m pg_sim.scenes.vpg_import FILE --out YAML [--mesh-dir DIR] [--name NAME] [--source S] [--frame F]
    [--workspace-centre X Y] [--centre workspace|rows] [--margin M] [--target-row K] [--target-color C]``."""
    ap = argparse.ArgumentParser(prog="python -m pg_sim.scenes.vpg_import", description=__doc__.split("\n\n")[0])
    add_arguments(ap)
    return run(ap.parse_args(argv))


def run(args: argparse.Namespace) -> int:
    """Import ``args.file`` as parsed by ``add_arguments``; prints the skipped rows; 0 on success, 1 on an error."""
    try:
        result = import_case(args.file, args.mesh_dir, args.name, source=args.source, frame=args.frame,
                             workspace_centre=args.workspace_centre, centre=args.centre, margin=args.margin,
                             target_row=args.target_row, target_color=args.target_color, family=args.family)
        save_scene(result.scene, args.out)
    except (SceneError, OSError, ValueError) as e:
        print(f"error: {e}", file=sys.stderr)
        return 1
    scene = result.scene
    print(f"source: {result.workspace.describe()}, centre {result.workspace.centre} in the file"
          + (" (scene centred on its rows)" if args.centre == "rows" else ""))
    for row in result.skipped:
        print(f"skipped {row}")
    print(f"wrote {args.out}: {len(scene.objects)} objects ({len(result.skipped)} skipped), target {scene.target} "
          f"({scene.target_object.shape}, row {result.target_row})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
