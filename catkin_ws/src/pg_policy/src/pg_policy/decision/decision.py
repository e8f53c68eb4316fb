"""The test-time decision rule (DESIGN.md section 7): grasp if the masked max of Q_g exceeds a threshold, else push.

Q maps are (R, H, W) float arrays over R rotations (R = 16: rotation index r means yaw = r * 2 pi / R) and the
heightmap's (H, W) cells (row along y, column along x, DESIGN.md section 3). The grasp is chosen among the cells of
the grasp region (the target mask, optionally grown by `grasp_radius_m`); the push among the push region (by default
the target mask grown by ``PUSH_RADIUS_M``: a goal-conditioned push has to start near the target to free it).
The chosen cell becomes a TCP pose in `world`: (x, y) the cell centre, z from the local heights
(:func:`pg_core.action_geometry.grasp_z_at` with the rotation's yaw: the jaw line's pits included /
:func:`~pg_core.action_geometry.push_z`), yaw from the rotation.
Argmax ties go to the first maximum in C order (lowest rotation, then row, then column).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from pg_core.action_geometry import grasp_z_at, push_z
from pg_core.geometry import PrimitiveSpec
from pg_core.heightmap import Heightmap, pixel_to_world, rotation_yaw
from pg_core.target_mask import TargetNotVisible, dilate_mask

PUSH_RADIUS_M = 0.05  # default push region: cells within 5 cm of the target (25 cells at 0.002 m)
GRASP_RADIUS_M = 0.0  # default grasp region: the target mask itself
PRIMITIVES = ("grasp", "push")


@dataclass(frozen=True)
class Decision:
    """One chosen action.

    primitive: "grasp" or "push"; rotation: index r in [0, R); row, col: heightmap cell; q: the chosen Q map's value
    there; yaw: r * 2 pi / R (rad, about world z); x, y, z: TCP position in `world` (m; cell centre, primitive height);
    grasp_q: masked max of Q_g over the grasp region, the value compared with the threshold (-inf if the region
    was empty).
    """

    primitive: str
    rotation: int
    row: int
    col: int
    q: float
    yaw: float
    x: float
    y: float
    z: float
    grasp_q: float

    @property
    def position(self) -> tuple[float, float, float]:
        """(x, y, z) in `world`, metres."""
        return (self.x, self.y, self.z)


def grasp_region(target: np.ndarray, resolution: float, radius_m: float = GRASP_RADIUS_M) -> np.ndarray:
    """(H, W) bool: the target mask grown by `radius_m` metres (0 = the mask itself); resolution in m/cell."""
    return dilate_mask(target, resolution, radius_m)


def push_region(target: np.ndarray, resolution: float, radius_m: float = PUSH_RADIUS_M) -> np.ndarray:
    """(H, W) bool: the cells within `radius_m` metres of the target mask (target included); resolution in m/cell."""
    return dilate_mask(target, resolution, radius_m)


def regions(target: np.ndarray, heightmap: Heightmap) -> tuple[np.ndarray, np.ndarray]:
    """((H, W) bool grasp region, (H, W) bool push region) of the (H, W) bool `target` with the default radii, each
    restricted to the heightmap's valid cells: the regions `decide` chooses in, which the test-time rules must see
    too (a candidate the rules accept on an invalid cell would never be chosen, and the decision would fall to a
    candidate no rule had checked)."""
    valid = np.asarray(heightmap.valid, dtype=bool)
    res = heightmap.resolution
    return grasp_region(target, res) & valid, push_region(target, res) & valid


def _masked(q: np.ndarray, mask: np.ndarray) -> np.ndarray:
    """(R, H, W) float64 copy of `q` with -inf outside the (H, W) mask and at NaN; ValueError on a shape mismatch."""
    q = np.asarray(q, dtype=np.float64)
    mask = np.asarray(mask, dtype=bool)
    if q.ndim != 3 or q.shape[1:] != mask.shape:
        raise ValueError(f"Q map shape {q.shape} does not match mask {mask.shape} as (R, H, W)")
    return np.where(mask[None] & ~np.isnan(q), q, -np.inf)


def masked_argmax(q: np.ndarray, mask: np.ndarray) -> tuple[int, int, int, float]:
    """(rotation, row, col, value) of the max of (R, H, W) `q` over the cells where (H, W) `mask` is True.

    NaN counts as -inf; ties go to the first maximum in C order. Raises ValueError if no finite value is masked in.
    """
    masked = _masked(q, mask)
    flat = int(np.argmax(masked))
    value = float(masked.flat[flat])
    if not math.isfinite(value):
        raise ValueError("no finite Q value inside the mask (empty mask or all NaN/-inf)")
    r, row, col = np.unravel_index(flat, masked.shape)
    return int(r), int(row), int(col), value


def masked_max(q: np.ndarray, mask: np.ndarray) -> float:
    """Max of (R, H, W) `q` over the (H, W) `mask` cells (NaN ignored); -inf when nothing is masked in."""
    return float(_masked(q, mask).max())


def action_pose(heightmap: Heightmap, primitive: str, rotation: int, row: int, col: int, prims: PrimitiveSpec,
                rotations: int = 16) -> tuple[float, float, float, float]:
    """(x, y, z, yaw) in `world` (m, m, m, rad) of a primitive at a heightmap cell and rotation index.

    Raises ValueError for an unknown primitive, a rotation outside [0, rotations) or a cell outside the map.
    """
    if primitive not in PRIMITIVES:
        raise ValueError(f"unknown primitive {primitive!r}; expected one of {PRIMITIVES}")
    if not 0 <= rotation < rotations:
        raise ValueError(f"rotation index {rotation} outside [0, {rotations})")
    h, w = heightmap.height.shape
    if not (0 <= row < h and 0 <= col < w):
        raise ValueError(f"cell ({row}, {col}) outside the {h} x {w} heightmap")
    x, y = pixel_to_world(row, col, heightmap.bounds, heightmap.resolution)
    yaw = rotation_yaw(rotation, rotations)
    if primitive == "grasp":  # the cell's height, or below the rim of a pit along the jaw line at this yaw; both
        # rules then keep the palm clear of what lies under it at this yaw (pg_core.action_geometry.palm_clear_z)
        z = grasp_z_at(heightmap, row, col, prims, yaw=yaw)
    else:
        z = push_z(heightmap.height, row, col, prims, zmin=float(heightmap.bounds[2, 0]), yaw=yaw,
                   resolution=heightmap.resolution)
    return x, y, z, yaw


def decide(q_grasp: np.ndarray, q_push: np.ndarray, target: np.ndarray, heightmap: Heightmap, prims: PrimitiveSpec,
           grasp_threshold: float, push_mask: np.ndarray | None = None, grasp_mask: np.ndarray | None = None,
           push_radius_m: float = PUSH_RADIUS_M, grasp_radius_m: float = GRASP_RADIUS_M) -> Decision:
    """Grasp at the argmax of Q_g over the grasp region if that max exceeds `grasp_threshold`, else push at the argmax
    of Q_p over the push region.

    q_grasp, q_push: (R, H, W) float Q maps; target: (H, W) bool target mask; heightmap: the observation the maps were
    computed from (its validity restricts both regions); prims: primitive heights; grasp_threshold: compared with
    strict ">"; push_mask / grasp_mask: (H, W) bool regions replacing the defaults (target grown by `push_radius_m`
    / `grasp_radius_m` metres).
    Raises ValueError for mismatched shapes, TargetNotVisible (a ValueError) when a push is needed but the push
    region holds no finite Q value (e.g. an empty target mask).
    """
    q_grasp = np.asarray(q_grasp)
    q_push = np.asarray(q_push)
    target = np.asarray(target, dtype=bool)
    shape = heightmap.height.shape
    if target.shape != shape:
        raise ValueError(f"target mask shape {target.shape} does not match the heightmap {shape}")
    for name, q in (("q_grasp", q_grasp), ("q_push", q_push)):
        if q.ndim != 3 or q.shape[1:] != shape:
            raise ValueError(f"{name} must have shape (R, {shape[0]}, {shape[1]}), got {q.shape}")
    if q_grasp.shape != q_push.shape:
        raise ValueError(f"q_grasp {q_grasp.shape} and q_push {q_push.shape} differ")
    res = heightmap.resolution
    valid = np.asarray(heightmap.valid, dtype=bool)
    g_region = (grasp_region(target, res, grasp_radius_m) if grasp_mask is None
                else np.asarray(grasp_mask, dtype=bool)) & valid
    grasp_q = masked_max(q_grasp, g_region)
    if grasp_q > grasp_threshold:
        primitive = "grasp"
        r, row, col, value = masked_argmax(q_grasp, g_region)
    else:
        primitive = "push"
        p_region = (push_region(target, res, push_radius_m) if push_mask is None
                    else np.asarray(push_mask, dtype=bool)) & valid
        try:
            r, row, col, value = masked_argmax(q_push, p_region)
        except ValueError:
            raise TargetNotVisible("no push candidate: the push region is empty (target not visible?)") from None
    x, y, z, yaw = action_pose(heightmap, primitive, r, row, col, prims, rotations=q_grasp.shape[0])
    return Decision(primitive, r, row, col, value, yaw, x, y, z, grasp_q)
