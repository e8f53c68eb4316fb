"""The parallel jaw's footprint test on a heightmap: does a grasp at a given yaw and line fit the target, and how
much clearance do its fingers have from other objects?

Shared by the heuristic baseline (pg_policy.policies.heuristic_planner) and the learned policy's grasp check rule
(pg_policy.decision.rules.grasp_check). Everything is in `world` metres on the heightmap of pg_core.heightmap (rows
along y, columns along x, heights above the table). A grasp at yaw closes the fingers along u = (cos yaw, sin yaw);
v = (-sin yaw, cos yaw) runs along the finger pads.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from pg_core.geometry import Geometry
from pg_core.heightmap import OBJECT_HEIGHT_M, Heightmap, cell_centres, pixel_to_world, world_to_pixel


@dataclass(frozen=True)
class JawParams:
    """Tunables of the footprint test (metres unless stated)."""

    margin: float = 0.003  # free space demanded around the finger regions
    obstacle_tol: float = 0.004  # a neighbour blocks when higher than grasp z - tol
    occupied: float = OBJECT_HEIGHT_M  # cells higher than this hold an object (pg_core.heightmap)
    window: float = 0.10  # half-size of the region around the target that is examined
    min_band_cells: int = 10  # target cells needed between the finger pads for a grasp
    centre_line: float = 0.006  # half-width of the central strip of the pads
    chord_tol: float = 0.004  # the target may be this much narrower in the central strip than between the pads


class CellWindow:
    """World (x, y) of the cells of a square heightmap window (half-size `half` m around `centre`, or the whole map
    when `centre` is None) and their heights: `slice` (rows, cols), `xy` (N, 2) float64 m, `h` (N,) m."""

    def __init__(self, hm: Heightmap, centre: np.ndarray | None, half: float) -> None:
        res, b = hm.resolution, hm.bounds
        rows, cols = hm.height.shape
        if centre is None:
            r0, r1, c0, c1 = 0, rows, 0, cols
        else:
            rc, cc = world_to_pixel(float(centre[0]), float(centre[1]), b, res)
            k = int(math.ceil(half / res))
            r0, r1, c0, c1 = max(rc - k, 0), min(rc + k + 1, rows), max(cc - k, 0), min(cc + k + 1, cols)
        rr, cc_ = np.mgrid[r0:r1, c0:c1]
        self.slice = (slice(r0, r1), slice(c0, c1))
        self.xy = cell_centres(rr, cc_, b, res).reshape(-1, 2)
        self.h = hm.height[self.slice].reshape(-1)


def dilate(mask: np.ndarray, cells: int) -> np.ndarray:
    """(H, W) bool `mask` grown by `cells` cells (square structuring element); the mask itself for cells <= 0."""
    import cv2

    if cells <= 0:
        return mask
    k = np.ones((2 * cells + 1, 2 * cells + 1), np.uint8)
    return cv2.dilate(mask.astype(np.uint8), k).astype(bool)


def mask_centre(hm: Heightmap, mask: np.ndarray) -> np.ndarray:
    """World (x, y) in m of the mean cell centre of the non-empty (H, W) bool `mask`."""
    rows, cols = np.nonzero(mask)
    return np.array(pixel_to_world(rows.mean(), cols.mean(), hm.bounds, hm.resolution))


class JawFit:
    """The footprint test of one gripper geometry (open jaw `max_opening`, fingers `finger_size`)."""

    def __init__(self, geometry: Geometry, params: JawParams | None = None) -> None:
        self.p = params or JawParams()
        self.rotations = geometry.heightmap.rotations
        gr = geometry.gripper
        self.half_open = gr.max_opening / 2
        self.finger_t, self.finger_w = gr.finger_size[0], gr.finger_size[1]

    def around(self, hm: Heightmap, target: np.ndarray) -> tuple[CellWindow, np.ndarray]:
        """The examined window around a visible (non-empty) target and the (H, W) bool cells of other objects."""
        others = (hm.height > self.p.occupied) & ~dilate(target, 1)
        return CellWindow(hm, mask_centre(hm, target), self.p.window), others

    def grasp_fit(self, t_xy: np.ndarray, o_xy: np.ndarray, o_h: np.ndarray, centre: np.ndarray, yaw: float,
                  z_grasp: float, t_h: np.ndarray | None = None) -> tuple[float, np.ndarray, float] | None:
        """Clearance (m, >= 0 means free), the pad-centred grasp point and the target's width between the pads (m) of
        a grasp at `yaw` through `centre` with the fingertips at `z_grasp` (m).

        t_xy: (M, 2) target cells; o_xy, o_h: (K, 2) cells of other objects and their heights; t_h: (M,) the target
        cells' heights, when given the cells lower than z_grasp - obstacle_tol are left out (the pads pass over
        them: a mug's handle lying flat beside its body). None when the target does not fit between the pads, too
        few target cells lie between them, or the target is narrower in the pads' central strip than between them
        (the pads would touch it off the closing line: it squirts out).
        """
        p = self.p
        if t_h is not None:
            t_xy = t_xy[t_h > z_grasp - p.obstacle_tol]
        u = np.array([math.cos(yaw), math.sin(yaw)])
        v = np.array([-u[1], u[0]])
        rel = t_xy - centre
        t = rel @ v
        band = np.abs(t) <= self.finger_w / 2 + p.margin
        if int(band.sum()) < p.min_band_cells or t[band].min() > -p.centre_line or t[band].max() < p.centre_line:
            return None  # the central strip of the pads is not all on the target
        s = rel[band] @ u
        lo, hi = float(s.min()), float(s.max())
        if hi - lo > 2 * (self.half_open - p.margin):
            return None
        centre_line = np.abs(t) <= p.centre_line
        if not centre_line.any():
            return None
        sc = rel[centre_line] @ u
        if float(sc.max() - sc.min()) < (hi - lo) - p.chord_tol:
            return None  # the pads would first touch the target off the closing line: it squirts out (round, wedge)
        c2 = centre + 0.5 * (lo + hi) * u
        reach = self.half_open + self.finger_t + p.margin  # outer face of an open finger + margin
        block = o_h > z_grasp - p.obstacle_tol
        if not block.any():
            return 1.0, c2, hi - lo
        orel = o_xy[block] - c2
        ds = np.maximum(np.abs(orel @ u) - reach, 0.0)
        dt = np.maximum(np.abs(orel @ v) - (self.finger_w / 2 + p.margin), 0.0)
        dist = np.hypot(ds, dt)
        return (float(dist.min()) if (dist > 0).all() else -1.0), c2, hi - lo

    def grasp_fit_many(self, t_xy: np.ndarray, o_xy: np.ndarray, o_h: np.ndarray, centres: np.ndarray,
                       yaws: np.ndarray, z_grasp: np.ndarray,
                       t_h: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """`grasp_fit` for K grasps at once: (clearance (K,) m, grasp points (K, 2), widths (K,) m).

        centres (K, 2), yaws (K,), z_grasp (K,): the grasps; t_xy, o_xy, o_h, t_h as in `grasp_fit`. A grasp that
        `grasp_fit` answers None for gets clearance NaN; -1 where a neighbour stands in a finger's sweep; otherwise
        `grasp_fit`'s clearance up to float rounding (the sign, which the grasp check reads, is the same).
        """
        p = self.p
        centres = np.asarray(centres, dtype=np.float64).reshape(-1, 2)
        k = len(centres)
        u = np.stack([np.cos(yaws), np.sin(yaws)], axis=1)  # (K, 2)
        v = np.stack([-u[:, 1], u[:, 0]], axis=1)
        rel = t_xy[None] - centres[:, None]  # (K, M, 2)
        t = rel @ v[:, :, None]  # (K, M, 1): the same per-row dot product as grasp_fit's `rel @ v`
        t = t[..., 0]
        s = (rel @ u[:, :, None])[..., 0]
        band = np.abs(t) <= self.finger_w / 2 + p.margin
        if t_h is not None:  # the target's cells under the fingertips are not between the pads
            band &= t_h[None] > (np.asarray(z_grasp, dtype=np.float64).reshape(-1) - p.obstacle_tol)[:, None]
        inf = np.inf
        ok = band.sum(axis=1) >= p.min_band_cells
        ok &= ~(np.where(band, t, inf).min(axis=1) > -p.centre_line)
        ok &= ~(np.where(band, t, -inf).max(axis=1) < p.centre_line)
        lo, hi = np.where(band, s, inf).min(axis=1), np.where(band, s, -inf).max(axis=1)
        ok &= ~(hi - lo > 2 * (self.half_open - p.margin))
        line = (np.abs(t) <= p.centre_line) & (band if t_h is not None else True)
        ok &= line.any(axis=1)
        chord = np.where(line, s, -inf).max(axis=1) - np.where(line, s, inf).min(axis=1)
        ok &= ~(chord < (hi - lo) - p.chord_tol)
        mid = np.zeros(k)
        mid[ok] = 0.5 * (lo[ok] + hi[ok])  # only where the band holds cells: elsewhere lo + hi is inf - inf
        c2 = centres + mid[:, None] * u
        clearance = np.full(k, np.nan)
        idx = np.flatnonzero(ok)
        if idx.size:
            # neighbours of every fitting grasp at once, each grasp with its own blocking set (its grasp z); the
            # offsets along u and v as o . u - c2 . u: one (K_o, 2) x (2, n) product instead of (n, K_o, 2) arrays
            reach = self.half_open + self.finger_t + p.margin
            block = o_h[:, None] > (z_grasp[idx] - p.obstacle_tol)[None]  # (K_o, n)
            ui, vi, ci = u[idx], v[idx], c2[idx]
            ds = np.maximum(np.abs(o_xy @ ui.T - (ci * ui).sum(1)) - reach, 0.0)
            dt = np.maximum(np.abs(o_xy @ vi.T - (ci * vi).sum(1)) - (self.finger_w / 2 + p.margin), 0.0)
            nearest = np.sqrt(np.where(block, ds * ds + dt * dt, np.inf).min(axis=0, initial=np.inf))
            clearance[idx] = np.where(~block.any(axis=0), 1.0, np.where(nearest > 0, nearest, -1.0))
        return clearance, c2, np.where(ok, hi - lo, np.nan)
