"""The heightmap convention, the one place for it, and the reference (numpy) projection of a point cloud onto the
top-down workspace heightmap.

Convention (VPG/ravens, DESIGN.md section 3): col = floor((x - xmin)/res), row = floor((y - ymin)/res);
each cell keeps its HIGHEST point (explicit per-cell max), height = z - zmin clipped at >= 0, empty cells are 0 and
marked invalid; the colour of a cell is the colour of its highest point. Validity: a cell is valid when at least one
finite point falls in it; a depth hole (no return: depth 0 or NaN, a NaN point) is no point, so a cell that receives
none is invalid (height 0, colour black), never table: `valid` tells them apart. Cell (row, col) stands for its centre
(`pixel_to_world`, `cell_centres`, `cell_centre_axes`; back: `world_to_pixel`). Rotation index r of R means gripper
yaw r * 2 pi / R about world +z (`rotation_yaw`, `rotation_step`). Cells higher than OBJECT_HEIGHT_M hold an object.
A re-rank of a Q map examines its best TOP_K cells.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from pg_core.geometry import Geometry

OBJECT_HEIGHT_M = 0.008  # cells higher than this (m above the table) hold an object; lower ones are table
TOP_K = 200  # candidate cells a re-rank walks per map and decision (the best TOP_K of the primitive's region)


@dataclass(frozen=True)
class Heightmap:
    """color: (H, W, 3) uint8 RGB; height: (H, W) float32 metres above zmin; valid: (H, W) bool. Frame: `world`."""

    color: np.ndarray
    height: np.ndarray
    valid: np.ndarray
    resolution: float
    bounds: np.ndarray  # (3, 2) [[xmin, xmax], [ymin, ymax], [zmin, zmax]]


def transform_points(points: np.ndarray, pose: np.ndarray) -> np.ndarray:
    """Apply a 4x4 transform to (N, 3) points; returns float64 (N, 3)."""
    pts = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    return pts @ pose[:3, :3].T + pose[:3, 3]


def _cells(points: np.ndarray, bounds: np.ndarray, resolution: float):
    """Cell index of every usable point: (flat index (M,), height above zmin (M,), kept mask (N,), rows, cols)."""
    bounds = np.asarray(bounds, dtype=np.float64)
    cols = int(round((bounds[0, 1] - bounds[0, 0]) / resolution))
    rows = int(round((bounds[1, 1] - bounds[1, 0]) / resolution))
    pts = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    with np.errstate(invalid="ignore"):
        col = np.floor((pts[:, 0] - bounds[0, 0]) / resolution)
        row = np.floor((pts[:, 1] - bounds[1, 0]) / resolution)
        keep = np.all(np.isfinite(pts), axis=1) & (pts[:, 2] < bounds[2, 1])
        keep &= (col >= 0) & (col < cols) & (row >= 0) & (row < rows)
    flat = (row[keep] * cols + col[keep]).astype(np.int64)
    z = np.maximum(pts[keep, 2] - bounds[2, 0], 0.0)
    return flat, z, keep, rows, cols


def _top(flat: np.ndarray, z: np.ndarray, n: int) -> tuple[np.ndarray, np.ndarray]:
    """Per-cell maximum (explicit, order independent) and the mask of points that attain it."""
    top = np.full(n, -np.inf)
    np.maximum.at(top, flat, z)
    return top, z == top[flat]


def project(points: np.ndarray, colors: np.ndarray, bounds: np.ndarray, resolution: float) -> Heightmap:
    """Project (N, 3) points in `world` with (N, 3) uint8 colours onto a heightmap over `bounds`.

    Points outside the x/y range or at/above zmax are dropped; non-finite points are ignored.
    """
    flat, z, keep, rows, cols = _cells(points, bounds, resolution)
    rgb = np.asarray(colors, dtype=np.uint8).reshape(-1, 3)[keep]
    top, winner = _top(flat, z, rows * cols)
    valid = np.isfinite(top)
    color = np.zeros((rows * cols, 3), dtype=np.uint8)
    color[flat[winner]] = rgb[winner]  # the colour of the highest point of each cell
    height = np.where(valid, top, 0.0).astype(np.float32)
    return Heightmap(
        color=color.reshape(rows, cols, 3),
        height=height.reshape(rows, cols),
        valid=valid.reshape(rows, cols),
        resolution=float(resolution),
        bounds=np.asarray(bounds, dtype=np.float64).copy(),
    )


def project_labels(points: np.ndarray, labels: np.ndarray, bounds: np.ndarray, resolution: float,
                   empty: int = -1) -> np.ndarray:
    """(H, W) int64 map of the label of each cell's highest point (`empty` where no point fell)."""
    flat, z, keep, rows, cols = _cells(points, bounds, resolution)
    lab = np.asarray(labels).reshape(-1)[keep]
    _, winner = _top(flat, z, rows * cols)
    out = np.full(rows * cols, empty, dtype=np.int64)
    out[flat[winner]] = lab[winner]
    return out.reshape(rows, cols)


def from_camera_cloud(
    points_cam: np.ndarray, colors: np.ndarray, camera_pose: np.ndarray, geometry: Geometry
) -> Heightmap:
    """Heightmap from a cloud in the camera optical frame and the 4x4 pose world <- camera."""
    world_pts = transform_points(points_cam, camera_pose)
    return project(world_pts, colors, geometry.workspace.bounds, geometry.heightmap.resolution)


def _centre(index: Any, low: float, resolution: float) -> Any:
    """Centre coordinate of cell index `index` (scalar or array) along an axis starting at `low`."""
    return low + (index + 0.5) * resolution


def pixel_to_world(row: float, col: float, bounds: np.ndarray, resolution: float) -> tuple[float, float]:
    """Cell centre (x, y) in `world` of heightmap cell (row, col) (fractional indices: the same affine map)."""
    return float(_centre(col, bounds[0, 0], resolution)), float(_centre(row, bounds[1, 0], resolution))


def cell_centres(rows: np.ndarray, cols: np.ndarray, bounds: np.ndarray, resolution: float) -> np.ndarray:
    """(N, 2) cell centres (x, y) in `world` of the cells (rows[i], cols[i]); pixel_to_world for many cells."""
    rows, cols = np.asarray(rows), np.asarray(cols)
    return np.stack([_centre(cols, bounds[0, 0], resolution), _centre(rows, bounds[1, 0], resolution)], axis=-1)


def cell_centre_axes(rows: int, cols: int, bounds: np.ndarray, resolution: float) -> tuple[np.ndarray, np.ndarray]:
    """(xs (cols,), ys (rows,)): the x of each column's and the y of each row's cell centres in `world`."""
    return _centre(np.arange(cols), bounds[0, 0], resolution), _centre(np.arange(rows), bounds[1, 0], resolution)


def world_to_pixel(x: float, y: float, bounds: np.ndarray, resolution: float) -> tuple[int, int]:
    """(row, col) of the cell holding world point (x, y); may fall outside the map."""
    return int(np.floor((y - bounds[1, 0]) / resolution)), int(np.floor((x - bounds[0, 0]) / resolution))


def rotation_yaw(rotation: Any, rotations: int) -> Any:
    """Gripper yaw (rad, counter-clockwise about world +z) of rotation index `rotation` (an int or an array of them)
    of `rotations` (R): rotation * 2 pi / R."""
    return rotation * 2 * math.pi / rotations


def rotation_step(rotations: int) -> float:
    """The yaw (rad) between neighbouring rotation indices of `rotations`: 2 pi / R."""
    return 2 * math.pi / rotations
