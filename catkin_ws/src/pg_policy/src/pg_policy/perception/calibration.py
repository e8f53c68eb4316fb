"""Camera extrinsics from a calibration YAML (launch/robot.launch), ROS-free.

File keys: parent, child (frame names), xyz (m), and either quaternion [x, y, z, w] or rpy [r, p, y] (rad, fixed
axes X-Y-Z as in URDF). Raises CalibrationError naming the file and the key for anything missing or malformed.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import yaml
from scipy.spatial.transform import Rotation


class CalibrationError(ValueError):
    pass


@dataclass(frozen=True)
class Extrinsics:
    parent: str
    child: str
    xyz: tuple[float, float, float]
    quaternion: tuple[float, float, float, float]  # x, y, z, w (unit)


def _vector(data: dict, key: str, n: int, where: str) -> np.ndarray:
    try:
        v = np.asarray(data[key], dtype=np.float64)
    except KeyError:
        raise CalibrationError(f"{where}: missing key '{key}'") from None
    except (TypeError, ValueError):
        raise CalibrationError(f"{where}: '{key}' must be {n} numbers") from None
    if v.shape != (n,) or not np.isfinite(v).all():
        raise CalibrationError(f"{where}: '{key}' must be {n} finite numbers, got {data[key]!r}")
    return v


def load_extrinsics(path: str | Path) -> Extrinsics:
    where = str(path)
    try:
        data = yaml.safe_load(Path(path).read_text())
    except OSError as exc:
        raise CalibrationError(f"cannot read calibration {where}: {exc}") from None
    except yaml.YAMLError as exc:
        raise CalibrationError(f"{where}: not valid YAML: {exc}") from None
    if not isinstance(data, dict):
        raise CalibrationError(f"{where}: expected a mapping with parent, child, xyz and quaternion or rpy")
    for key in ("parent", "child"):
        if not isinstance(data.get(key), str) or not data[key]:
            raise CalibrationError(f"{where}: '{key}' must be a frame name")
    xyz = _vector(data, "xyz", 3, where)
    if ("quaternion" in data) == ("rpy" in data):
        raise CalibrationError(f"{where}: give exactly one of 'quaternion' and 'rpy'")
    if "quaternion" in data:
        q = _vector(data, "quaternion", 4, where)
        norm = float(np.linalg.norm(q))
        if abs(norm - 1.0) > 1e-3:
            raise CalibrationError(f"{where}: quaternion norm is {norm:.4f}, not 1")
        q = q / norm
    else:
        q = Rotation.from_euler("xyz", _vector(data, "rpy", 3, where)).as_quat()
    return Extrinsics(data["parent"], data["child"], tuple(float(v) for v in xyz), tuple(float(v) for v in q))
