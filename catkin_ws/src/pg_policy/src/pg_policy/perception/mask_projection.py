"""A camera-image mask onto the heightmap grid, by projecting each heightmap cell through the camera (no ROS).

Each valid heightmap cell stands for one 3D point in `world`: its cell centre (x, y) (pg_core.heightmap
`cell_centre_axes`) at z = zmin + its height. That point goes through the `world` -> camera optical frame transform
(REP 103 optical frame: x right, y down, z forward) and the pinhole model K (pixel-centre convention, as the
geometry config's cx, cy: pixel (0, 0)'s centre is at (0.0, 0.0), so pixel index = round(u), round(v)); the cell is
the target when the mask is set at that pixel. Invalid cells (no point seen) and cells whose point lies behind the
camera or outside the image are not the target. Sampling is nearest-pixel: one sample per cell.

Shapes and units: image masks are (h, w) (rows along the image's v, columns along u), nonzero = set; grid masks are
(H, W) bool over the heightmap cells (rows along y, columns along x); transforms are 4x4 homogeneous matrices in
metres; quaternions are (x, y, z, w) as geometry_msgs orders them.
"""

from __future__ import annotations

import numpy as np

from pg_core.heightmap import Heightmap, cell_centre_axes


def quaternion_matrix(translation: tuple[float, float, float] | np.ndarray,
                      quaternion: tuple[float, float, float, float] | np.ndarray) -> np.ndarray:
    """4x4 transform of a translation (m) and a unit quaternion (x, y, z, w) (normalised here); ValueError for a
    zero or non-finite quaternion."""
    q = np.asarray(quaternion, dtype=np.float64)
    n = float(np.linalg.norm(q))
    if q.shape != (4,) or not np.isfinite(n) or n < 1e-9:
        raise ValueError(f"quaternion must be 4 finite numbers, not all zero, got {tuple(q)}")
    x, y, z, w = q / n
    out = np.eye(4)
    out[:3, :3] = [[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                   [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                   [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]]
    out[:3, 3] = np.asarray(translation, dtype=np.float64)
    return out


def cell_points(hm: Heightmap) -> np.ndarray:
    """(H, W, 3) float64: each cell's 3D point in `world` (cell centre x, y; z = zmin + height)."""
    rows, cols = np.asarray(hm.height).shape
    xs, ys = cell_centre_axes(rows, cols, hm.bounds, hm.resolution)
    gx, gy = np.meshgrid(xs, ys)  # (H, W): x along columns, y along rows
    gz = float(hm.bounds[2, 0]) + np.asarray(hm.height, dtype=np.float64)
    return np.stack([gx, gy, gz], axis=-1)


def project_cells(hm: Heightmap, intrinsics: np.ndarray, camera_from_world: np.ndarray,
                  image_size: tuple[int, int]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Pixel of every cell's point: (v (H, W) int, u (H, W) int, seen (H, W) bool). `intrinsics`: 3x3 K;
    `camera_from_world`: 4x4 optical frame <- `world`; `image_size`: (width, height) px. `seen`: the cell is valid,
    its point lies in front of the camera and lands inside the image (v, u are 0 where not)."""
    width, height = image_size
    k = np.asarray(intrinsics, dtype=np.float64)
    pts = cell_points(hm)
    cam = pts @ np.asarray(camera_from_world, dtype=np.float64)[:3, :3].T + np.asarray(camera_from_world)[:3, 3]
    z = cam[..., 2]
    front = z > 1e-6
    zs = np.where(front, z, 1.0)
    u = np.floor(k[0, 0] * cam[..., 0] / zs + k[0, 1] * cam[..., 1] / zs + k[0, 2] + 0.5)
    v = np.floor(k[1, 1] * cam[..., 1] / zs + k[1, 2] + 0.5)
    seen = np.asarray(hm.valid, dtype=bool) & front & (u >= 0) & (u < width) & (v >= 0) & (v < height)
    return np.where(seen, v, 0).astype(np.int64), np.where(seen, u, 0).astype(np.int64), seen


def project_mask(mask: np.ndarray, hm: Heightmap, intrinsics: np.ndarray, camera_from_world: np.ndarray) -> np.ndarray:
    """(H, W) bool grid mask of the (h, w) image mask (nonzero = set) taken by the camera with 3x3 K `intrinsics`
    and 4x4 `camera_from_world` (optical frame <- `world`), sampled at each cell's projection (module docstring).
    ValueError for a mask that is not 2-D."""
    image = np.asarray(mask)
    if image.ndim != 2:
        raise ValueError(f"mask must be an (h, w) image, got shape {image.shape}")
    v, u, seen = project_cells(hm, intrinsics, camera_from_world, (image.shape[1], image.shape[0]))
    return seen & (image[v, u] != 0)
