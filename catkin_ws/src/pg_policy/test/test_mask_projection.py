"""pg_policy.perception.mask_projection with a synthetic pinhole camera: a box on the table is rendered into a
camera mask by ray casting and projected back onto the heightmap grid."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from pg_core.geometry import pose_matrix
from pg_core.heightmap import Heightmap, cell_centre_axes
from pg_policy.perception.mask_projection import project_mask, quaternion_matrix

N, RES = 224, 0.002
BOUNDS = np.array([[-0.224, 0.224], [-0.224, 0.224], [0.0, 0.4]])
K = np.array([[615.0, 0.0, 319.5], [0.0, 615.0, 239.5], [0.0, 0.0, 1.0]])
SIZE = (640, 480)  # width, height px
TOP_DOWN = pose_matrix((0.0, 0.0, 0.70), (np.pi, 0.0, -np.pi / 2))  # world <- optical, as workspace.yaml's camera


def look_at(eye: tuple[float, float, float], target: tuple[float, float, float]) -> np.ndarray:
    """world <- optical pose of a camera at `eye` looking at `target` (optical z forward, y down, x right)."""
    z = np.subtract(target, eye) / np.linalg.norm(np.subtract(target, eye))
    x = np.cross(z, (0.0, 0.0, 1.0))
    x /= np.linalg.norm(x)
    pose = np.eye(4)
    pose[:3, :3] = np.stack([x, np.cross(z, x), z], axis=1)
    pose[:3, 3] = eye
    return pose


def slab_hits(origin: np.ndarray, dirs: np.ndarray, lo: np.ndarray, hi: np.ndarray, t_max: float) -> np.ndarray:
    """(N,) bool: whether origin + t dirs[i] meets the box [lo, hi] for some t in (0, t_max)."""
    with np.errstate(divide="ignore", invalid="ignore"):
        t1, t2 = (lo - origin) / dirs, (hi - origin) / dirs
    near = np.nanmax(np.minimum(t1, t2), axis=1)
    far = np.nanmin(np.maximum(t1, t2), axis=1)
    return (near <= far) & (far > 0) & (near < t_max)


def scene(pose: np.ndarray, lo: tuple[float, float, float], hi: tuple[float, float, float]):
    """(heightmap, rendered (h, w) uint8 camera mask, expected (H, W) grid mask) of box [lo, hi] on the table."""
    lo_, hi_ = np.array(lo), np.array(hi)
    xs, ys = cell_centre_axes(N, N, BOUNDS, RES)
    gx, gy = np.meshgrid(xs, ys)
    box = (gx > lo[0]) & (gx < hi[0]) & (gy > lo[1]) & (gy < hi[1])
    height = np.where(box, hi[2], 0.0).astype(np.float32)
    # table cells hidden behind the box are not seen by the camera: invalid, as in a real heightmap
    eye = pose[:3, 3]
    table = np.stack([gx.ravel(), gy.ravel(), np.zeros(gx.size)], axis=1)
    hidden = slab_hits(eye, table - eye, lo_ - 1e-9, hi_ + 1e-9, 1.0 - 1e-6).reshape(N, N) & ~box
    color = np.full((N, N, 3), 128, np.uint8)
    hm = Heightmap(color, height, ~hidden, RES, BOUNDS)
    u, v = np.meshgrid(np.arange(SIZE[0]), np.arange(SIZE[1]))
    rays = np.stack([(u - K[0, 2]) / K[0, 0], (v - K[1, 2]) / K[1, 1], np.ones_like(u, float)], axis=-1)
    dirs = rays.reshape(-1, 3) @ pose[:3, :3].T
    rendered = slab_hits(eye, dirs, lo_, hi_, np.inf).reshape(SIZE[1], SIZE[0]).astype(np.uint8) * 255
    return hm, rendered, box


def iou(a: np.ndarray, b: np.ndarray) -> float:
    return float((a & b).sum() / (a | b).sum())


@pytest.mark.parametrize("pose", [TOP_DOWN, look_at((0.35, -0.1, 0.55), (0.0, 0.0, 0.0))], ids=["top-down", "oblique"])
@pytest.mark.parametrize("box", [((0.04, -0.06, 0.0), (0.08, -0.02, 0.05)), ((-0.13, 0.05, 0.0), (-0.07, 0.13, 0.03))])
def test_rendered_box_projects_back(pose, box) -> None:
    hm, rendered, expected = scene(pose, *box)
    assert rendered.any()
    grid = project_mask(rendered, hm, K, np.linalg.inv(pose))
    assert grid.shape == (N, N) and grid.dtype == bool
    assert iou(grid, expected) > 0.97


def test_cells_outside_the_image_or_invalid_are_not_the_target() -> None:
    hm, _, _ = scene(TOP_DOWN, (0.04, -0.06, 0.0), (0.08, -0.02, 0.05))
    everything = np.full((SIZE[1], SIZE[0]), 255, np.uint8)
    grid = project_mask(everything, hm, K, np.linalg.inv(TOP_DOWN))
    assert grid.sum() == hm.valid.sum()  # the whole workspace is in view: every valid cell
    small = np.full((SIZE[1] // 2 + 5, SIZE[0] // 2 + 5), 255, np.uint8)  # cropped image: the cells landing in it
    cropped = project_mask(small, hm, K, np.linalg.inv(TOP_DOWN))
    assert 0 < cropped.sum() < grid.sum()
    assert not cropped[:, : N // 2 - 10].any() and not cropped[: N // 2 - 10].any()  # optical x = -y, y = -x
    behind = np.linalg.inv(pose_matrix((0.0, 0.0, -0.1), (np.pi, 0.0, 0.0)))  # below the table, looking down
    assert not project_mask(everything, hm, K, behind).any()


def test_mask_must_be_2d() -> None:
    hm, _, _ = scene(TOP_DOWN, (0.04, -0.06, 0.0), (0.08, -0.02, 0.05))
    with pytest.raises(ValueError, match="mask"):
        project_mask(np.zeros((4, 4, 3), np.uint8), hm, K, np.eye(4))


def test_quaternion_matrix_matches_the_pose() -> None:
    pose = look_at((0.35, -0.1, 0.55), (0.0, 0.0, 0.0))
    q = Rotation.from_matrix(pose[:3, :3]).as_quat()  # (x, y, z, w)
    assert np.allclose(quaternion_matrix(pose[:3, 3], q * 2.0), pose)
    with pytest.raises(ValueError, match="quaternion"):
        quaternion_matrix((0, 0, 0), (0, 0, 0, 0))
