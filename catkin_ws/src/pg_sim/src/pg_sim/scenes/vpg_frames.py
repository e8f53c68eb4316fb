"""Frames and source workspaces of the VPG / Xu / [K] text test cases (the geometry of ``pg_sim.scenes.vpg_import``).

Frames (how a file's numbers are read; ``frame`` = auto | coppeliasim | gazebo):
- ``coppeliasim`` (VPG, Xu et al., the paper's case 2-6): the angles are CoppeliaSim's Euler angles,
  R = Rx(alpha) Ry(beta) Rz(gamma) (elemental rotations about the absolute Z, then Y, then X axes; CoppeliaSim manual,
  "Euler angles"), applied to the meshes in their .obj frame, which is our shapes' frame. x and y are read as they are.
- ``gazebo`` (the paper's case 1, 7-9, 11-14; x ~ 0.5-0.75): Gazebo world poses with x and y swapped with respect to
  the authors' ``gazebo_world.sdf`` (which is the consistent scene: swapping x/y alone mirrors positions but not
  orientations). We swap them back, read the angles as SDF roll-pitch-yaw (fixed axes x, y, z: R = Rz Ry Rx) of the
  authors' Gazebo models, whose frames differ from the .obj frames: ``GAZEBO_MODEL_FRAMES`` (inferred by matching the
  SDF copies of case 2-6 against the CoppeliaSim files) maps our shape frame to theirs; then the scene is turned by
  -90 deg about z so that it has the orientation of the CoppeliaSim files: file (x, y) -> (x, -y).

Source workspaces (``SOURCES``; the square of side 0.448 m, as ours, that the source simulator's heightmap covers),
with their centres in the FILE's coordinates (mapping that centre onto `world` puts every object where the source put
it relative to its workspace):
- ``vpg``: VPG's CoppeliaSim workspace x in [-0.724, -0.276], y in [-0.224, 0.224]: centre (-0.5, 0).
- ``xu``: Xu et al.'s loader (and the paper authors' [K], docs/DESIGN.md section 6) adds +0.1 m to the file's y
  before placing an object in that same CoppeliaSim workspace (their main.py keeps y in [-0.224, 0.224]), so in the
  file's coordinates the workspace is y in [-0.324, 0.124]: centre (-0.5, -0.1); the object lands at
  (x + 0.5, y + 0.1) in `world`, exactly where their simulator put it. (Their test files are VPG's, e.g.
  test-10-obj-00.txt differs from VPG's in one y lowered by 0.02 m so that the +0.1 shift keeps it in view; the two
  cannot be told apart from the rows, so ``auto`` never picks ``xu``.)
- ``gazebo``: centre (0.655, 0.007) in the Gazebo-frame file (x, y), i.e. (0.655, -0.007) after the frame's turn:
  the mean over case 2-6 of the translation between the CoppeliaSim file and its SDF copy (mapped by the frame logic
  above) plus VPG's centre (-0.5, 0) (0.6546, -0.0075; the per-case translations scatter by +-0.03 m, the authors
  placed each copy by hand). All rows of the Gazebo-frame cases lie within 0.13 m of it.
``auto`` (source and frame): a row votes for the VPG or the Gazebo workspace when it lies inside it (with the margin);
the majority wins (parked rows vote for neither), giving ``vpg`` or ``gazebo``.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

from scipy.spatial.transform import Rotation

from pg_sim.scenes.scene import SceneError
from pg_sim.scenes.shapes import REGISTRY

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
GAZEBO_MIN_X = 0.25  # m: a custom workspace centre with x beyond this is taken for the Gazebo frame under frame auto
FRAMES = ("auto", "coppeliasim", "gazebo")
SOURCE_CHOICES = ("auto", "vpg", "xu", "gazebo")
WORKSPACE_HALF = 0.224  # m: half the side of the source workspaces (VPG's 0.448 m square; ours is the same)
WORKSPACE_Z = (0.0, 0.4)  # m: heights a resting object may have (VPG's z limits)
DEFAULT_MARGIN = 0.05  # m: how far beyond the source workspace a row may lie and still be imported


@dataclass(frozen=True)
class SourceWorkspace:
    """A source simulator's workspace: name, frame of its files and centre in the file's (x, y) coordinates."""

    name: str
    frame: str
    centre: tuple[float, float]

    def limits(self) -> tuple[tuple[float, float], tuple[float, float]]:
        """(x_min, x_max), (y_min, y_max) in the file's coordinates."""
        cx, cy = self.centre
        return (cx - WORKSPACE_HALF, cx + WORKSPACE_HALF), (cy - WORKSPACE_HALF, cy + WORKSPACE_HALF)

    def describe(self) -> str:
        (x0, x1), (y0, y1) = self.limits()
        return f"{self.name} workspace x [{x0:.3f}, {x1:.3f}], y [{y0:.3f}, {y1:.3f}] ({self.frame} frame)"

    def outside(self, position: Sequence[float], margin: float) -> str | None:
        """Why a file position (x, y, z) lies outside this workspace widened by ``margin``, or None when inside."""
        (x0, x1), (y0, y1) = self.limits()
        bounds = {"x": (x0, x1), "y": (y0, y1), "z": WORKSPACE_Z}
        why = [f"{axis} {v:.3f} not in [{lo - margin:.3f}, {hi + margin:.3f}]"
               for (axis, (lo, hi)), v in zip(bounds.items(), position, strict=True)
               if not lo - margin <= v <= hi + margin]
        return f"outside the {self.name} workspace (margin {margin:g} m): {', '.join(why)}" if why else None


SOURCES: dict[str, SourceWorkspace] = {
    "vpg": SourceWorkspace("vpg", "coppeliasim", (-0.5, 0.0)),
    "xu": SourceWorkspace("xu", "coppeliasim", (-0.5, -0.1)),
    "gazebo": SourceWorkspace("gazebo", "gazebo", (0.655, 0.007)),
}


def frame_xy(frame: str, x: float, y: float) -> tuple[float, float]:
    """A file's (x, y) turned into the orientation of `world` (not centred): gazebo (x, -y), coppeliasim as is."""
    return (x, -y) if frame == "gazebo" else (x, y)


def resolve_source(
    positions: Sequence[Sequence[float]],
    source: str = "auto",
    frame: str = "auto",
    workspace_centre: Sequence[float] | None = None,
    margin: float = DEFAULT_MARGIN,
) -> SourceWorkspace:
    """The workspace to map onto ours for a file whose rows have ``positions`` (file x, y, z).

    ``source`` picks a preset (``SOURCES``), ``workspace_centre`` (file coordinates) overrides its centre (name
    ``custom``), ``frame`` forces the frame (it must agree with an explicit source). Raises SceneError.
    """
    if source not in SOURCE_CHOICES:
        raise SceneError(f"unknown source {source!r}; use one of {', '.join(SOURCE_CHOICES)}")
    if frame not in FRAMES:
        raise SceneError(f"unknown frame {frame!r}; use one of {', '.join(FRAMES)}")
    if source != "auto":
        preset = SOURCES[source]
        if frame not in ("auto", preset.frame):
            raise SceneError(f"source {source!r} writes the {preset.frame} frame, not {frame!r}")
        frame = preset.frame
    if workspace_centre is not None:
        centre = tuple(float(v) for v in workspace_centre)
        if len(centre) != 2 or not all(math.isfinite(v) for v in centre):
            raise SceneError(f"workspace centre must be two finite numbers X Y, got {list(workspace_centre)!r}")
        if frame == "auto":
            frame = "gazebo" if centre[0] > GAZEBO_MIN_X else "coppeliasim"
        return SourceWorkspace("custom", frame, (centre[0], centre[1]))
    if source != "auto":
        return SOURCES[source]
    if frame == "auto":
        votes = {name: sum(SOURCES[name].outside(p, margin) is None for p in positions) for name in ("vpg", "gazebo")}
        if not any(votes.values()):
            raise SceneError(f"no row lies in a known workspace ({SOURCES['vpg'].describe()}; "
                             f"{SOURCES['gazebo'].describe()}); pass a source or a workspace centre")
        frame = "gazebo" if votes["gazebo"] > votes["vpg"] else "coppeliasim"
    return SOURCES["gazebo" if frame == "gazebo" else "vpg"]


def orientation(shape: str, frame: str, angles: Sequence[float]) -> Rotation:
    """World rotation of our shape (before the household yaw-only rule) for the file's angles."""
    a, b, g = angles
    if frame == "coppeliasim":
        return Rotation.from_euler("XYZ", [a, b, g])  # intrinsic x-y'-z'' = R = Rx(a) Ry(b) Rz(g)
    model = GAZEBO_MODEL_FRAMES.get(shape, Rotation.identity())
    return Rotation.from_euler("z", -90, degrees=True) * Rotation.from_euler("xyz", [a, b, g]) * model


def household_rotation(shape: str, rot: Rotation) -> Rotation:
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
