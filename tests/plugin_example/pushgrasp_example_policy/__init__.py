"""An example pushgrasp policy plug-in: grasp the target at its centroid, closing across its narrow axis.

Registered as ``example-centroid`` in the entry-point group ``pushgrasp.policies`` (see this distribution's
pyproject.toml and docs/PLUGINS.md of pushgrasp); `pushgrasp eval --policy example-centroid`, `pushgrasp infer` and
the policy node (``policy:=example-centroid``) run it.

Conventions (pg_core.heightmap, DESIGN.md section 3): the heightmap is (H, W) cells over the workspace box in the
`world` frame, row along +y, column along +x, resolution in metres per cell, heights in metres above the table.
Positions are in `world` metres, yaws in radians about +z. Rotation index r means yaw = r * 2 pi / R
(R = geometry.heightmap.rotations, 16); a grasp at yaw closes the fingers along u = (cos yaw, sin yaw), a push
starts at the cell with closed fingers and travels prims.push_length metres along u.

The rule, per decision:
1. The target mask is the cells of the target's colour (pg_core.target_mask.target_mask on the colour heightmap).
2. With at least ``MIN_GRASP_CELLS`` cells, narrower than the open gripper across its narrow axis, and fewer than
   ``GRASPS_BEFORE_PUSH`` failed grasps in a row: grasp at the mask cell nearest the mask's centroid, closing along
   the minor principal axis of the mask cells (the rotation nearest that axis).
3. Otherwise push from beside: the closed fingers start just outside the target (or, when it is not visible at all,
   outside the pile of objects), on the side of the neighbouring objects, and push it away from them; directions
   that would carry it out of the workspace are skipped. Without neighbours it is pushed towards the workspace
   centre; with the target not visible at all, in a direction drawn from the policy's seeded generator.
"""

from __future__ import annotations

import math
from typing import Protocol

import numpy as np

from pg_core.geometry import Geometry, load
from pg_core.heightmap import OBJECT_HEIGHT_M, Heightmap, rotation_step
from pg_core.target_mask import MIN_VISIBLE_CELLS, target_mask
from pg_policy.decision.decision import Decision, action_pose
from pg_policy.policies.policy import PolicyOptions

__all__ = ["CentroidGraspPolicy"]

MIN_GRASP_CELLS = 60  # target cells needed to grasp (2.4 cm^2 at 0.002 m/cell); fewer: push from beside
GRASPS_BEFORE_PUSH = 2  # failed grasps in a row after which the next action pushes the target free
NEIGHBOUR_RADIUS_M = 0.06  # object cells within this distance of the target's centroid count as its neighbours
PUSH_GAP_M = 0.005  # gap between the closed fingers and the target's edge at the push start
MAX_BACKOFF_M = 0.04  # how much farther back the push start may move to find a free cell
EDGE_MARGIN_M = 0.03  # the target's predicted centre after a push stays this far inside the workspace


class Observation(Protocol):
    """What the policy reads: the colour heightmap (`world` frame) and the target's palette colour name."""

    heightmap: Heightmap
    target: str


class CentroidGraspPolicy:
    """Centroid grasp across the target's narrow axis, push from beside as the fallback (module docstring).

    opts: pg_policy.policies.policy.PolicyOptions; used are `geometry` (default: pg_core.geometry.load()) and `seed`
    (the generator's seed before the first reset). Keeps no Q maps; `last_note` says why it took its last decision.
    """

    name = "example-centroid"

    def __init__(self, opts: PolicyOptions) -> None:
        self.geometry: Geometry = opts.geometry or load()
        self.prims = self.geometry.primitives
        self.rotations = int(self.geometry.heightmap.rotations)
        self.max_opening_m = float(self.geometry.gripper.max_opening)
        # the closed fingers are two finger thicknesses along the push direction, centred on the start cell
        self.clearance_m = float(self.geometry.gripper.finger_size[0]) + PUSH_GAP_M
        self.rng = np.random.default_rng(opts.seed)
        self.grasps_in_row = 0
        self.last_note = ""

    def reset(self, seed: int | None = None) -> None:
        """Start a new trial: reseed the generator, forget the failed grasps."""
        self.rng = np.random.default_rng(seed)
        self.grasps_in_row = 0
        self.last_note = ""

    def q_maps(self) -> dict[str, np.ndarray]:
        """No Q maps: an empty dict."""
        return {}

    def act(self, obs: Observation) -> Decision:
        """The next action on `obs` (module docstring). A call after a grasp in the same trial means that grasp
        missed the target. Raises ValueError for an unknown target colour name."""
        hm = obs.heightmap
        mask = target_mask(hm.color, hm.valid, obs.target)
        cells = int(mask.sum())
        if cells < MIN_VISIBLE_CELLS:
            objects = (hm.height > OBJECT_HEIGHT_M) & hm.valid
            region = mask | objects if objects.any() else np.ones_like(mask)
            angle = float(self.rng.uniform(0.0, 2.0 * math.pi))
            return self._push_beside(hm, region, angle, f"target not visible ({cells} cells): push the pile apart")
        if cells < MIN_GRASP_CELLS:
            return self._push_beside(hm, mask, None, f"target too small to grasp ({cells} < {MIN_GRASP_CELLS} "
                                     "cells): push it free")
        if self.grasps_in_row >= GRASPS_BEFORE_PUSH:
            return self._push_beside(hm, mask, None, f"{self.grasps_in_row} grasps missed: push the target free")
        rows, cols = np.nonzero(mask)
        minor = principal_axes(rows, cols)[1]
        centre = np.array([cols.mean(), rows.mean()])
        across = (np.stack([cols, rows], axis=1) - centre) @ minor
        width_m = float(across.max() - across.min() + 1.0) * hm.resolution
        if width_m > self.max_opening_m:
            return self._push_beside(hm, mask, None, f"target {100 * width_m:.1f} cm across its narrow axis, wider "
                                     f"than the open gripper: push it")
        nearest = int(np.argmin((cols - centre[0]) ** 2 + (rows - centre[1]) ** 2))
        rotation = nearest_rotation(math.atan2(minor[1], minor[0]), self.rotations, symmetric=True)
        self.grasps_in_row += 1
        self.last_note = f"grasp at the target's centroid across its narrow axis ({100 * width_m:.1f} cm)"
        return self._decision(hm, "grasp", rotation, int(rows[nearest]), int(cols[nearest]))

    # -- pushes ---------------------------------------------------------------------------------------------------
    def _push_beside(self, hm: Heightmap, region: np.ndarray, angle: float | None, note: str) -> Decision:
        """A push that starts just outside `region` ((H, W) bool) and travels into it: along `angle` (rad, `world`)
        when given, else away from the neighbouring objects (towards the workspace centre without neighbours).
        Directions are tried nearest first; the first whose start lies on the map and whose predicted end keeps
        the region's centroid EDGE_MARGIN_M inside the workspace wins (else the nearest direction)."""
        rows, cols = np.nonzero(region)
        pts = np.stack([cols, rows], axis=1).astype(float)  # (N, 2) cells as (x, y)
        centre = pts.mean(axis=0)
        if angle is None:
            angle = self._away_from_neighbours(hm, region, centre)
        step = rotation_step(self.rotations)
        first = nearest_rotation(angle, self.rotations)
        order = sorted(range(self.rotations), key=lambda r: abs(math.remainder(r * step - angle, 2.0 * math.pi)))
        travel_cells = max(self.prims.push_length - self.clearance_m, 0.0) / hm.resolution
        chosen: tuple[int, int, int] | None = None
        for r in [first, *[k for k in order if k != first]]:
            u = np.array([math.cos(r * step), math.sin(r * step)])
            start = self._start_cell(hm, region, pts, centre, u)
            if start is None or not self._inside(hm, centre + travel_cells * u):
                continue
            chosen = (r, *start)
            break
        if chosen is None:  # no direction keeps the target inside: the preferred one, start clipped to the map
            u = np.array([math.cos(first * step), math.sin(first * step)])
            back = centre - (self._behind(pts, centre, u) + self.clearance_m / hm.resolution) * u
            h, w = region.shape
            chosen = (first, int(np.clip(round(back[1]), 0, h - 1)), int(np.clip(round(back[0]), 0, w - 1)))
        self.grasps_in_row = 0
        self.last_note = note
        return self._decision(hm, "push", *chosen)

    def _away_from_neighbours(self, hm: Heightmap, region: np.ndarray, centre: np.ndarray) -> float:
        """Direction (rad, `world`) from the centroid of the object cells near `centre` (cells, (x, y)) towards it;
        towards the workspace centre when there are none, a seeded random one when already there."""
        h, w = region.shape
        yy, xx = np.mgrid[0:h, 0:w]
        near = (xx - centre[0]) ** 2 + (yy - centre[1]) ** 2 <= (NEIGHBOUR_RADIUS_M / hm.resolution) ** 2
        neighbours = near & (hm.height > OBJECT_HEIGHT_M) & hm.valid & ~region
        if neighbours.any():
            away = centre - np.array([xx[neighbours].mean(), yy[neighbours].mean()])
        else:
            away = np.array([(w - 1) / 2.0, (h - 1) / 2.0]) - centre
        if float(np.hypot(*away)) < 1.0:
            return float(self.rng.uniform(0.0, 2.0 * math.pi))
        return math.atan2(float(away[1]), float(away[0]))

    @staticmethod
    def _behind(pts: np.ndarray, centre: np.ndarray, u: np.ndarray) -> float:
        """How far (cells) the region reaches behind its centroid along -u."""
        return float(-((pts - centre) @ u).min())

    def _start_cell(self, hm: Heightmap, region: np.ndarray, pts: np.ndarray, centre: np.ndarray,
                    u: np.ndarray) -> tuple[int, int] | None:
        """(row, col) of the push start behind the region along -u: the first cell, backing off up to
        MAX_BACKOFF_M, that is on the map, off the region and free of objects; the first on-map cell off the region
        when none is free; None when the start would leave the map."""
        h, w = region.shape
        base = self._behind(pts, centre, u) + self.clearance_m / hm.resolution
        fallback: tuple[int, int] | None = None
        for k in range(int(MAX_BACKOFF_M / hm.resolution) + 1):
            x, y = centre - (base + k) * u
            row, col = int(round(y)), int(round(x))
            if not (0 <= row < h and 0 <= col < w):
                break
            if region[row, col]:
                continue
            if hm.height[row, col] <= OBJECT_HEIGHT_M:
                return row, col
            fallback = fallback or (row, col)
        return fallback

    @staticmethod
    def _inside(hm: Heightmap, xy_cells: np.ndarray) -> bool:
        """Whether a point given in cells (x, y) lies EDGE_MARGIN_M inside the map's borders."""
        margin = EDGE_MARGIN_M / hm.resolution
        h, w = hm.height.shape
        return bool(margin <= xy_cells[0] <= w - 1 - margin and margin <= xy_cells[1] <= h - 1 - margin)

    def _decision(self, hm: Heightmap, primitive: str, rotation: int, row: int, col: int) -> Decision:
        """The Decision of a primitive at a cell and rotation index; pose in `world` (m, rad), no Q values (NaN)."""
        x, y, z, yaw = action_pose(hm, primitive, rotation, row, col, self.prims, self.rotations)
        return Decision(primitive, rotation, row, col, math.nan, yaw, x, y, z, math.nan)


def principal_axes(rows: np.ndarray, cols: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(major, minor) unit vectors (x, y) in `world` of the principal axes of the cells (rows[i], cols[i]): the
    eigenvectors of their (x, y) covariance, largest eigenvalue first. One cell: (1, 0) and (0, 1)."""
    if len(rows) < 2:
        return np.array([1.0, 0.0]), np.array([0.0, 1.0])
    _, vecs = np.linalg.eigh(np.cov(np.stack([cols, rows]).astype(float)))
    return vecs[:, 1], vecs[:, 0]


def nearest_rotation(angle: float, rotations: int, symmetric: bool = False) -> int:
    """The rotation index r in [0, rotations) whose yaw r * 2 pi / rotations is nearest `angle` (rad); symmetric
    (a parallel jaw's closing axis: r and r + rotations / 2 are the same grasp): the one in [0, rotations / 2)."""
    r = int(round(angle / rotation_step(rotations))) % rotations
    return r % (rotations // 2) if symmetric and rotations % 2 == 0 else r
