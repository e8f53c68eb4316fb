"""Sensor data in the layouts the ROS messages want, built with numpy only (no ROS, no per-point Python loops).

- Organised point cloud: an (H, W) structured array with float32 fields x, y, z (metres, camera optical frame) and
  rgb (PCL's packed colour: uint32 0x00RRGGBB stored in a float32), 16 bytes per point; NaN x/y/z where the depth
  image has no return. Its bytes are the `data` of a sensor_msgs/PointCloud2 with fields x(0) y(4) z(8) rgb(12).
- Depth: 32FC1 metres with NaN where there is no return (REP 118).
- Object markers: the geometry of every scene object as rviz primitives (boxes, cylinders, triangle lists, meshes),
  computed once per object and posed per publish.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial.transform import Rotation

from pg_sim.scenes.meshes import load_obj
from pg_sim.scenes.scene import ObjectSpec
from pg_sim.scenes.shapes import REGISTRY

CLOUD_DTYPE = np.dtype({"names": ["x", "y", "z", "rgb"], "formats": ["<f4"] * 4, "offsets": [0, 4, 8, 12],
                        "itemsize": 16})
# (name, byte offset) of the PointCloud2 fields, all FLOAT32 with count 1
CLOUD_FIELDS = (("x", 0), ("y", 4), ("z", 8), ("rgb", 12))


class CloudBuilder:
    """Back-projects depth + colour images of a fixed pinhole camera into organised clouds (rays cached)."""

    def __init__(self, k: np.ndarray, width: int, height: int) -> None:
        v, u = np.mgrid[0:height, 0:width]
        self.rx = ((u - k[0, 2]) / k[0, 0]).astype(np.float32)
        self.ry = ((v - k[1, 2]) / k[1, 1]).astype(np.float32)
        self.shape = (height, width)

    def build(self, depth: np.ndarray, color: np.ndarray) -> np.ndarray:
        """(H, W) CLOUD_DTYPE array from depth (H, W) metres (<= 0 or NaN: no return) and colour (H, W, 3) uint8."""
        if depth.shape != self.shape or color.shape[:2] != self.shape:
            raise ValueError(f"images {depth.shape} / {color.shape} do not match the camera size {self.shape}")
        z = np.asarray(depth, dtype=np.float32)
        z = np.where(z > 0, z, np.float32(np.nan))  # NaN stays NaN (NaN > 0 is false)
        cloud = np.empty(self.shape, dtype=CLOUD_DTYPE)
        cloud["x"] = self.rx * z
        cloud["y"] = self.ry * z
        cloud["z"] = z
        c = color.astype(np.uint32)
        cloud["rgb"] = ((c[..., 0] << 16) | (c[..., 1] << 8) | c[..., 2]).view(np.float32)
        return cloud


def depth_with_nan(depth: np.ndarray) -> np.ndarray:
    """32FC1 depth (metres) with NaN where there is no return (the sim camera writes 0 there)."""
    d = np.asarray(depth, dtype=np.float32)
    return np.where(d > 0, d, np.float32(np.nan)).astype(np.float32)


def unpack_rgb(rgb: np.ndarray) -> np.ndarray:
    """Packed float32 rgb field -> (..., 3) uint8 colours (the inverse of the cloud's packing)."""
    u = np.ascontiguousarray(rgb, dtype=np.float32).view(np.uint32)
    return np.stack([(u >> 16) & 255, (u >> 8) & 255, u & 255], axis=-1).astype(np.uint8)


# --------------------------------------------------------------------------------------------------------- markers
@dataclass(frozen=True)
class MarkerPart:
    """One rviz primitive of an object, posed in the object's frame.

    kind: "cube" (scale = extents), "cylinder" (scale = diameter, diameter, height; axis z), "triangles" (points:
    (3N, 3) vertices of a triangle list, scale 1) or "mesh" (mesh: absolute .obj path, scale = mesh scale).
    """

    kind: str
    position: tuple[float, float, float]
    quaternion: tuple[float, float, float, float]  # x, y, z, w
    scale: tuple[float, float, float]
    points: np.ndarray | None = None
    mesh: str | None = None


@dataclass(frozen=True)
class ObjectMarker:
    """A marker part posed in `world`: position, quaternion (x, y, z, w), the object's name and RGBA (0-1)."""

    object_name: str
    part: MarkerPart
    position: tuple[float, float, float]
    quaternion: tuple[float, float, float, float]
    rgba: tuple[float, float, float, float]


def _prism_triangles(polygon: tuple[tuple[float, float], ...], half_z: float) -> np.ndarray:
    """Triangle list of a convex counter-clockwise polygon extruded over z in [-half_z, half_z]."""
    poly = np.asarray(polygon, dtype=np.float64)
    n = len(poly)
    top = np.column_stack([poly, np.full(n, half_z)])
    bot = np.column_stack([poly, np.full(n, -half_z)])
    tris = []
    for i in range(1, n - 1):
        tris += [top[0], top[i], top[i + 1], bot[0], bot[i + 1], bot[i]]
    for i in range(n):
        j = (i + 1) % n
        tris += [bot[i], bot[j], top[j], bot[i], top[j], top[i]]
    return np.asarray(tris)


def marker_parts(spec: ObjectSpec) -> list[MarkerPart]:
    """The rviz primitives of one object (shapes from the registry; meshes as mesh resources)."""
    if spec.shape == "mesh":
        if not spec.mesh:
            return []
        v = load_obj(spec.mesh).vertices * np.asarray(spec.scale)
        centre = -(v.min(axis=0) + v.max(axis=0)) / 2.0
        return [MarkerPart("mesh", (float(centre[0]), float(centre[1]), float(centre[2])), (0.0, 0.0, 0.0, 1.0),
                           tuple(float(s) for s in spec.scale), mesh=spec.mesh)]  # type: ignore[arg-type]
    parts = []
    for q in REGISTRY[spec.shape].parts(spec.size):
        pos = tuple(float(v) for v in q.pos)
        quat = tuple(float(v) for v in q.quat)
        if q.kind == "box":
            parts.append(MarkerPart("cube", pos, quat, tuple(2.0 * float(d) for d in q.dims)))  # type: ignore[arg-type]
        elif q.kind == "cylinder":
            r, h = float(q.dims[0]), float(q.dims[1])
            parts.append(MarkerPart("cylinder", pos, quat, (2 * r, 2 * r, h)))  # type: ignore[arg-type]
        else:
            parts.append(MarkerPart("triangles", pos, quat, (1.0, 1.0, 1.0),  # type: ignore[arg-type]
                                    points=_prism_triangles(q.polygon, float(q.dims[0]))))
    return parts


def pose_parts(name: str, parts: list[MarkerPart], position: np.ndarray, quaternion: np.ndarray,
               rgba: tuple[float, float, float, float]) -> list[ObjectMarker]:
    """Place an object's parts at its world pose (position, quaternion x, y, z, w)."""
    rot = Rotation.from_quat(quaternion)
    out = []
    for part in parts:
        pos = rot.apply(part.position) + np.asarray(position)
        quat = (rot * Rotation.from_quat(part.quaternion)).as_quat()
        out.append(ObjectMarker(name, part, (float(pos[0]), float(pos[1]), float(pos[2])),
                                (float(quat[0]), float(quat[1]), float(quat[2]), float(quat[3])), rgba))
    return out
