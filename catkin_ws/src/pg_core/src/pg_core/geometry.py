"""Load the shared geometry config (config/workspace.yaml): the one place Python reads it.

Every length is in metres, every angle in radians, poses are in `world` unless a field says otherwise.
Raises FileNotFoundError for a missing file and ValueError (naming the key) for a malformed one.
"""

from __future__ import annotations

import math
import os
from dataclasses import MISSING, dataclass, replace
from functools import lru_cache
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from pg_core import resources

CONFIG_ENV = "PG_WORKSPACE_CONFIG"


def __getattr__(name: str) -> Any:
    if name == "DEFAULT_CONFIG":  # pg_description's config/workspace.yaml, found when first asked for
        return resources.geometry_config()
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


@dataclass(frozen=True)
class Workspace:
    x: tuple[float, float]
    y: tuple[float, float]
    z: tuple[float, float]

    @property
    def bounds(self) -> np.ndarray:
        """(3, 2) array [[xmin, xmax], [ymin, ymax], [zmin, zmax]]."""
        return np.array([self.x, self.y, self.z], dtype=np.float64)

    def contains(self, p: np.ndarray, tol: float = 1e-9) -> bool:
        b = self.bounds
        p = np.asarray(p, dtype=np.float64)
        return bool(np.all(p >= b[:, 0] - tol) and np.all(p <= b[:, 1] + tol))


@dataclass(frozen=True)
class HeightmapSpec:
    resolution: float
    rotations: int
    rows: int  # along y
    cols: int  # along x


@dataclass(frozen=True)
class CameraSpec:
    width: int
    height: int
    fx: float
    fy: float
    cx: float
    cy: float
    near: float
    far: float
    xyz: tuple[float, float, float]
    rpy: tuple[float, float, float]

    @property
    def intrinsics(self) -> np.ndarray:
        """3x3 pinhole matrix K (pixel-centre convention)."""
        return np.array([[self.fx, 0.0, self.cx], [0.0, self.fy, self.cy], [0.0, 0.0, 1.0]])

    @property
    def pose(self) -> np.ndarray:
        """4x4 transform world <- camera_color_optical_frame."""
        return pose_matrix(self.xyz, self.rpy)


@dataclass(frozen=True)
class ArmSpec:
    name: str
    xyz: tuple[float, float, float]
    rpy: tuple[float, float, float]
    home: tuple[float, ...]
    ik_branch: tuple[int, int, int]  # (shoulder, wrist, elbow) signs of the closed-form IK branch


@dataclass(frozen=True)
class RobotSpec:
    urdf: Path
    dh_d: tuple[float, ...]
    dh_a: tuple[float, ...]
    dh_alpha: tuple[float, ...]
    link_masses: tuple[float, ...]
    joint_names: tuple[str, ...]
    joint_lower: tuple[float, ...]
    joint_upper: tuple[float, ...]
    joint_velocity_limit: float
    joint_effort_limit: tuple[float, ...]
    arms: dict[str, ArmSpec]


@dataclass(frozen=True)
class GripperSpec:
    max_opening: float
    tcp_offset: float
    palm_size: tuple[float, float, float]
    finger_size: tuple[float, float, float]
    finger_mass: float
    palm_mass: float
    finger_force: float
    finger_speed: float
    closed_threshold: float
    # Lateral friction coefficient of the finger pads (simulation: the fingers' URDF <contact>, and set on the finger
    # links when the robot loads; PyBullet multiplies it with an object's own). Absent: 0.5, PyBullet's default.
    pad_friction: float = 0.5
    # Rolling friction of the finger pads (m; simulation): how far a pad's contact resists turning about an axis in
    # the contact plane (a plate hanging from a pinched rim), as a rubber pad's contact patch does; PyBullet combines
    # it with the object's friction. Absent or 0: point contacts, no such resistance.
    pad_rolling_friction: float = 0.0


@dataclass(frozen=True)
class PrimitiveSpec:
    approach_height: float
    transit_height: float
    grasp_depth: float
    grasp_min_z: float
    lift_height: float
    push_length: float
    push_depth: float
    push_min_z: float
    push_window_px: int
    cartesian_speed: float
    push_speed: float
    waypoint_step: float
    time_budget: float
    # Guarded grasp descent: the approach stops where the fingers meet an upward contact force above this (N) from
    # an object or the table, as a real arm's force limit would; 0 = descend to the planned z regardless. Optional
    # in the YAML (0 when absent).
    grasp_stop_force: float = 0.0
    # Guarded push descent: the closed fingers stop coming down where the objects press up on them and the palm with
    # more than this (N), and the push travels from there; 0 = descend to the planned z regardless. Optional.
    push_stop_force: float = 0.0
    # Low objects (pg_core.action_geometry.grasp_z_for_height): local heights h in [lo, hi) m take the fingertip z
    # max(grasp_low_fraction * h, grasp_low_min_z) instead of max(h - grasp_depth, grasp_min_z). Optional in the
    # YAML; absent = an empty range, the DESIGN section 4 rule everywhere.
    grasp_low_heights: tuple[float, float] = (0.0, 0.0)
    grasp_low_fraction: float = 0.0
    grasp_low_min_z: float = 0.0
    # Pits along the jaw line (pg_core.action_geometry.rim_pit / grasp_z with a yaw): where the grasp cell lies in an
    # object's pit next to a wall standing grasp_rim_step above it (thin: it falls as much within grasp_rim_wall),
    # within grasp_rim_reach along the closing line, the fingertip z is max(rim - grasp_rim_depth, floor +
    # grasp_rim_clearance). Optional in the YAML; absent (grasp_rim_step 0) = the cell's height alone everywhere.
    grasp_rim_depth: float = 0.0
    grasp_rim_clearance: float = 0.0
    grasp_rim_step: float = 0.0
    grasp_rim_wall: float = 0.0
    grasp_rim_reach: float = 0.0
    # Palm clearance (pg_core.action_geometry.palm_clear_z): the fingertip z is at least the highest cell under the
    # palm's footprint - the finger length + this (m), so that the palm never drives into an object. Optional in the
    # YAML; absent (None) = no palm rule. palm_footprint (x along the closing axis, y; m) and finger_length (m) are
    # not YAML keys: `parse` copies them from gripper.palm_size and gripper.finger_size.
    grasp_palm_clearance: float | None = None
    palm_footprint: tuple[float, float] = (0.0, 0.0)
    finger_length: float = 0.0
    # Raised parts (pg_core.action_geometry.raised_part / grasp_z with a yaw): where the grasp cell lies on a part of
    # an object that stands out by a wall at least grasp_part_step high within the open jaw, the object going on under
    # both fingers, the fingertip z is grasp_part_clearance above the highest cell the fingers pass over, the part's
    # edges at least grasp_part_contact above that (the foot ring of a bowl upside down). Optional in the YAML;
    # absent (grasp_part_step 0) = no raised parts. finger_thickness (m, along the closing axis) is not a YAML key:
    # `parse` copies it from gripper.finger_size.
    grasp_part_step: float = 0.0
    grasp_part_clearance: float = 0.0
    grasp_part_contact: float = 0.0
    finger_thickness: float = 0.0


@dataclass(frozen=True)
class TableSpec:
    size: tuple[float, float, float]
    center_xy: tuple[float, float]


@dataclass(frozen=True)
class Geometry:
    path: Path
    world_frame: str
    camera_frame: str
    workspace: Workspace
    heightmap: HeightmapSpec
    camera: CameraSpec
    table: TableSpec
    robot: RobotSpec
    gripper: GripperSpec
    primitives: PrimitiveSpec


def pose_matrix(xyz: Any, rpy: Any) -> np.ndarray:
    """4x4 homogeneous transform from a translation and ROS fixed-axis roll-pitch-yaw."""
    from scipy.spatial.transform import Rotation

    t = np.eye(4)
    t[:3, :3] = Rotation.from_euler("xyz", rpy).as_matrix()
    t[:3, 3] = xyz
    return t


def _get(d: dict, key: str, where: str) -> Any:
    if not isinstance(d, dict) or key not in d:
        raise ValueError(f"geometry config: missing key '{where}{key}'")
    return d[key]


def _tuple(d: dict, key: str, where: str, n: int | None = None) -> tuple[float, ...]:
    v = _get(d, key, where)
    if not isinstance(v, list) or (n is not None and len(v) != n):
        raise ValueError(f"geometry config: '{where}{key}' must be a list of {n or 'some'} numbers, got {v!r}")
    return tuple(float(x) for x in v)


def _section(raw: dict, name: str, cls: type, lists: dict[str, int | None]) -> Any:
    sec = _get(raw, name, "")
    kwargs = {}
    for field, spec in cls.__dataclass_fields__.items():
        if isinstance(sec, dict) and field not in sec and spec.default is not MISSING:
            kwargs[field] = spec.default
        elif field in lists:
            kwargs[field] = _tuple(sec, field, f"{name}.", lists[field])
        else:
            kwargs[field] = _get(sec, field, f"{name}.")
    return cls(**kwargs)


def _robot(raw: dict) -> RobotSpec:
    sec = _get(raw, "robot", "")
    dh = _get(sec, "dh", "robot.")
    arms = {}
    for name, arm in _get(sec, "arms", "robot.").items():
        w = f"robot.arms.{name}."
        branch = tuple(int(v) for v in _tuple(arm, "ik_branch", w, 3))
        if any(v not in (1, -1) for v in branch):
            raise ValueError(f"geometry config: '{w}ik_branch' must hold three signs (1 or -1), got {branch}")
        arms[name] = ArmSpec(name, _tuple(arm, "xyz", w, 3), _tuple(arm, "rpy", w, 3), _tuple(arm, "home", w, 6),
                             branch)
    return RobotSpec(
        urdf=resources.package_file(str(_get(sec, "urdf", "robot."))),  # "<package>/<path inside it>"
        dh_d=_tuple(dh, "d", "robot.dh.", 6),
        dh_a=_tuple(dh, "a", "robot.dh.", 6),
        dh_alpha=_tuple(dh, "alpha", "robot.dh.", 6),
        link_masses=_tuple(sec, "link_masses", "robot.", 6),
        joint_names=tuple(str(n) for n in _get(sec, "joint_names", "robot.")),
        joint_lower=_tuple(sec, "joint_lower", "robot.", 6),
        joint_upper=_tuple(sec, "joint_upper", "robot.", 6),
        joint_velocity_limit=float(_get(sec, "joint_velocity_limit", "robot.")),
        joint_effort_limit=_tuple(sec, "joint_effort_limit", "robot.", 6),
        arms=arms,
    )


def _check_low_grasp(prims: PrimitiveSpec) -> None:
    """ValueError naming the key unless the low-object grasp keys hold 0 <= lo <= hi, a fraction in [0, 1] and a
    z >= 0, and the jaw-line pit and raised-part keys (grasp_rim_*, grasp_part_*) finite lengths >= 0."""
    lo, hi = prims.grasp_low_heights
    checks = {
        "grasp_low_heights": (0.0 <= lo <= hi, f"must be [lo, hi] heights with 0 <= lo <= hi (m), got [{lo}, {hi}]"),
        "grasp_low_fraction": (isinstance(prims.grasp_low_fraction, int | float)
                               and 0.0 <= prims.grasp_low_fraction <= 1.0,
                               f"must lie in [0, 1], got {prims.grasp_low_fraction!r}"),
        "grasp_low_min_z": (isinstance(prims.grasp_low_min_z, int | float) and prims.grasp_low_min_z >= 0.0,
                            f"must be a height >= 0 m, got {prims.grasp_low_min_z!r}"),
    }
    for key in ("grasp_rim_depth", "grasp_rim_clearance", "grasp_rim_step", "grasp_rim_wall", "grasp_rim_reach",
                "grasp_part_step", "grasp_part_clearance", "grasp_part_contact"):
        value = getattr(prims, key)
        checks[key] = (isinstance(value, int | float) and not isinstance(value, bool) and 0.0 <= value < math.inf,
                       f"must be a length >= 0 m, got {value!r}")
    palm = prims.grasp_palm_clearance
    checks["grasp_palm_clearance"] = (palm is None or (isinstance(palm, int | float) and not isinstance(palm, bool)
                                                       and 0.0 <= palm < math.inf),
                                      f"must be a length >= 0 m or absent, got {palm!r}")
    for key, (ok, what) in checks.items():
        if not ok:
            raise ValueError(f"geometry config: 'primitives.{key}' {what}")


def parse(raw: dict, path: Path) -> Geometry:
    """Build a Geometry from the parsed YAML mapping; raises ValueError naming the bad key."""
    ws = _section(raw, "workspace", Workspace, {"x": 2, "y": 2, "z": 2})
    hm = _get(raw, "heightmap", "")
    res = float(_get(hm, "resolution", "heightmap."))
    heightmap = HeightmapSpec(
        resolution=res,
        rotations=int(_get(hm, "rotations", "heightmap.")),
        rows=int(round((ws.y[1] - ws.y[0]) / res)),
        cols=int(round((ws.x[1] - ws.x[0]) / res)),
    )
    frames = _get(raw, "frames", "")
    primitives = _section(raw, "primitives", PrimitiveSpec, {"grasp_low_heights": 2})
    for key in ("grasp_stop_force", "push_stop_force"):
        force = getattr(primitives, key)
        if not isinstance(force, int | float) or isinstance(force, bool) or not 0 <= force < math.inf:
            raise ValueError(f"geometry config: 'primitives.{key}' must be a force >= 0 N (0 = off), got {force!r}")
    _check_low_grasp(primitives)
    gripper = _section(raw, "gripper", GripperSpec, {"palm_size": 3, "finger_size": 3})
    primitives = replace(primitives, palm_footprint=(gripper.palm_size[0], gripper.palm_size[1]),
                         finger_length=gripper.finger_size[2], finger_thickness=gripper.finger_size[0])
    return Geometry(
        path=path,
        world_frame=str(_get(frames, "world", "frames.")),
        camera_frame=str(_get(frames, "camera", "frames.")),
        workspace=ws,
        heightmap=heightmap,
        camera=_section(raw, "camera", CameraSpec, {"xyz": 3, "rpy": 3}),
        table=_section(raw, "table", TableSpec, {"size": 3, "center_xy": 2}),
        robot=_robot(raw),
        gripper=gripper,
        primitives=primitives,
    )


@lru_cache(maxsize=8)
def _load_cached(path: str) -> Geometry:
    p = Path(path)
    if not p.is_file():
        raise FileNotFoundError(f"geometry config not found: {p}")
    with p.open() as f:
        raw = yaml.safe_load(f)
    if not isinstance(raw, dict):
        raise ValueError(f"geometry config {p} is not a YAML mapping")
    return parse(raw, p)


def load(path: str | Path | None = None) -> Geometry:
    """The geometry config at `path`, else $PG_WORKSPACE_CONFIG, else the package's config/workspace.yaml."""
    chosen = path or os.environ.get(CONFIG_ENV) or resources.geometry_config()
    return _load_cached(str(Path(chosen).resolve()))
