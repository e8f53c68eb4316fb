"""Mesh helpers of the household objects (pg_sim.objects.household): convex pieces and the draw of an object.

Every builder describes its object as convex trimesh pieces in metres, in the object's canonical frame (z up; the
pieces' union is the object). The visual mesh is the boolean union of the pieces (manifold3d), so what the camera sees
and what collides are the same solid, and the collision decomposition is exact by construction: no decomposition
run is needed. Pieces may overlap (the union and the physics do not mind).

Round things are polygons of ``SECTIONS`` sides whose faces, not corners, lie at +-x and +-y (``ring``), and whose
faces touch the nominal circle (the polygon circumscribes it), so a bottle lying along x rests on a face and a
diameter d measures d across faces.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np
import trimesh

Parts = list[trimesh.Trimesh]
SECTIONS = 20  # sides of a revolved polygon (a multiple of 4: faces at +-x and +-y)
STEEL, ALUMINIUM, CERAMIC, GLASS = 7800.0, 2700.0, 2300.0, 2500.0  # kg/m^3
PLASTIC, ABS, RUBBER, WOOD = 1000.0, 1050.0, 1100.0, 650.0


@dataclass
class Draw:
    """The parameters of one object: the main dimension and shape variant its split allows (drawn first, see
    household.split_params), then the builder's further draws from the same generator, recorded in ``params``."""

    rng: np.random.Generator
    main: float
    variant: str
    params: dict[str, float | str] = field(default_factory=dict)

    def u(self, name: str, lo: float, hi: float) -> float:
        """A uniform draw in [lo, hi), recorded as ``params[name]``."""
        value = float(self.rng.uniform(lo, hi))
        self.params[name] = value
        return value


@dataclass
class Shape:
    """What a builder returns: groups of convex pieces (canonical frame, m) with their density (kg/m^3), the
    roll/pitch/yaw (rad) of the resting pose, and for containers the inner radius at the rim and the inner depth (m)."""

    groups: list[tuple[Parts, float]]
    rest_rpy: tuple[float, float, float] = (0.0, 0.0, 0.0)
    inner_radius: float = 0.0
    inner_depth: float = 0.0

    @property
    def parts(self) -> Parts:
        return [p for parts, _ in self.groups for p in parts]


Builder = Callable[[Draw], Shape]


# ------------------------------------------------------------------------------------------------------------ pieces
def hull(points: np.ndarray | Sequence[Sequence[float]]) -> trimesh.Trimesh:
    """The convex hull of 3-D points (m). Raises scipy's QhullError for flat or degenerate point sets."""
    return trimesh.convex.convex_hull(np.asarray(points, dtype=np.float64))


def ring(radius: float, n: int = SECTIONS, z: float = 0.0) -> np.ndarray:
    """(n, 3) corners of an n-gon about the z axis whose faces touch the circle ``radius`` (one face on +x)."""
    t = 2 * np.pi * np.arange(n) / n + np.pi / n
    r = radius / math.cos(math.pi / n)
    return np.column_stack([r * np.cos(t), r * np.sin(t), np.full(n, z)])


def frustum(r0: float, z0: float, r1: float, z1: float, n: int = SECTIONS,
            c0: tuple[float, float] = (0.0, 0.0), c1: tuple[float, float] | None = None) -> trimesh.Trimesh:
    """The hull of an n-gon of radius r0 at height z0 (centre c0 in x-y) and one of r1 at z1 (centre c1 = c0)."""
    a = ring(max(r0, 1e-4), n, z0)
    b = ring(max(r1, 1e-4), n, z1)
    a[:, :2] += c0
    b[:, :2] += c0 if c1 is None else c1
    return hull(np.vstack([a, b]))


def stack(profile: Sequence[tuple[float, float]], n: int = SECTIONS) -> Parts:
    """A solid of revolution about z from its (radius, z) profile, bottom to top: one frustum per profile step
    (steps of no height, ledges, add nothing)."""
    return [frustum(r0, z0, r1, z1, n) for (r0, z0), (r1, z1) in zip(profile[:-1], profile[1:], strict=True)
            if z1 - z0 > 1e-7]


def revolve(poly: np.ndarray | Sequence[Sequence[float]], n: int = SECTIONS) -> Parts:
    """A convex (r, z) polygon off the axis (r > 0) revolved about z: its n sector pieces, each exactly convex (the
    hull of the polygon at two neighbouring angles: its faces between the angles are planar)."""
    rz = np.asarray(poly, dtype=np.float64) * [1.0 / math.cos(math.pi / n), 1.0]
    t = 2 * np.pi * np.arange(n + 1) / n + np.pi / n
    out = []
    for a, b in zip(t[:-1], t[1:], strict=True):
        pts = [(r * math.cos(ang), r * math.sin(ang), z) for r, z in rz for ang in (a, b)]
        out.append(hull(pts))
    return out


def wall(outer: np.ndarray, thickness: float, n: int = SECTIONS) -> Parts:
    """A thin revolved wall: ``outer`` (k, 2) is its outer (r, z) line, bottom to rim; the inner line is offset by
    ``thickness`` (m) to the left of it (inwards and up for a bowl), its rim flat at the outer rim's height. One
    quad per segment, revolved."""
    outer = np.asarray(outer, dtype=np.float64)
    seg = np.diff(outer, axis=0)
    seg /= np.linalg.norm(seg, axis=1)[:, None]
    normals = np.column_stack([-seg[:, 1], seg[:, 0]])  # the segment direction turned +90 deg
    vert = np.vstack([normals[:1], normals[:-1] + normals[1:], normals[-1:]])
    vert /= np.linalg.norm(vert, axis=1)[:, None]
    beside = np.vstack([normals, normals[-1:]])  # a segment touching each vertex: the bisector is equally far from both
    miter = thickness / np.maximum(np.einsum("ij,ij->i", vert, beside), 0.3)
    inner = outer + vert * miter[:, None]
    if seg[-1, 1] > 0.1:  # a flat rim: slide the inner rim point along the wall down to the outer rim's height
        inner[-1] -= seg[-1] * (inner[-1, 1] - outer[-1, 1]) / seg[-1, 1]
    out: Parts = []
    for i in range(len(outer) - 1):
        out += revolve([outer[i], outer[i + 1], inner[i + 1], inner[i]], n)
    return out


def box(extents: Sequence[float], at: Sequence[float] = (0.0, 0.0, 0.0), yaw: float = 0.0) -> trimesh.Trimesh:
    """A box of extents (x, y, z) m turned by ``yaw`` (rad) about z, centred at ``at``."""
    m = trimesh.creation.box(extents=[max(float(e), 2e-4) for e in extents])
    m.apply_transform(trimesh.transformations.rotation_matrix(yaw, [0, 0, 1]))
    m.apply_translation(at)
    return m


def prism(polygon: np.ndarray | Sequence[Sequence[float]], z0: float, z1: float) -> trimesh.Trimesh:
    """A convex x-y polygon (m) extruded from z0 to z1."""
    xy = np.asarray(polygon, dtype=np.float64)
    return hull(np.vstack([np.column_stack([xy, np.full(len(xy), z)]) for z in (z0, z1)]))


def rounded_rect(w: float, h: float, k: int = 2) -> np.ndarray:
    """(m, 2) corners of a w x h rectangle with chamfered (k > 0) corners, centred, counter-clockwise."""
    c = min(w, h) * 0.25 if k else 0.0
    a, b = w / 2, h / 2
    return np.array([(a - c, -b), (a, -b + c), (a, b - c), (a - c, b), (-a + c, b), (-a, b - c), (-a, -b + c),
                     (-a + c, -b)])


def ellipse(a: float, b: float, k: int = 8) -> np.ndarray:
    """(k, 2) corners of an ellipse polygon with semi-axes a, b (a flat side at -b)."""
    t = 2 * np.pi * np.arange(k) / k - np.pi / 2 + np.pi / k
    return np.column_stack([a * np.cos(t), b * np.sin(t)]) / math.cos(math.pi / k)


def sweep(path: np.ndarray | Sequence[Sequence[float]], sections: Sequence[np.ndarray] | np.ndarray,
          normal: Sequence[float] = (0.0, 0.0, 1.0), closed: bool = False) -> Parts:
    """Pieces of a tube along a polyline ``path`` (M, 3) lying in a plane of unit ``normal``: the section polygon
    (u, v) at each path point lies across the path, u in the plane, v along ``normal``; piece i is the hull of
    sections i and i + 1. ``sections`` is one (k, 2) polygon or one per path point."""
    pts = np.asarray(path, dtype=np.float64)
    m = len(pts)
    secs = [np.asarray(sections)] * m if np.asarray(sections[0]).ndim == 1 else [np.asarray(s) for s in sections]
    nv = np.asarray(normal, dtype=np.float64)
    rings = []
    for i in range(m):
        prev, nxt = pts[i - 1] if (closed or i > 0) else pts[i], pts[(i + 1) % m] if (closed or i < m - 1) else pts[i]
        tangent = nxt - prev
        tangent /= np.linalg.norm(tangent)
        u = np.cross(nv, tangent)
        rings.append(pts[i] + secs[i][:, :1] * u + secs[i][:, 1:2] * nv)
    pairs = range(m) if closed else range(m - 1)
    return [hull(np.vstack([rings[i], rings[(i + 1) % m]])) for i in pairs]


def ellipsoid(a: float, b: float, c: float, at: Sequence[float] = (0.0, 0.0, 0.0)) -> trimesh.Trimesh:
    m = trimesh.creation.icosphere(subdivisions=2, radius=1.0)
    m.apply_scale([a, b, c])
    m.apply_translation(at)
    return m


def moved(parts: Parts, matrix: np.ndarray) -> Parts:
    """Copies of ``parts`` transformed by the 4 x 4 ``matrix``."""
    out = []
    for p in parts:
        q = p.copy()
        q.apply_transform(matrix)
        out.append(q)
    return out


def rot(axis: str, angle: float, at: Sequence[float] = (0.0, 0.0, 0.0)) -> np.ndarray:
    """4 x 4: rotation by ``angle`` (rad) about the x, y or z axis, then translation by ``at``."""
    m = trimesh.transformations.rotation_matrix(angle, {"x": [1, 0, 0], "y": [0, 1, 0], "z": [0, 0, 1]}[axis])
    m[:3, 3] = at
    return m


def union(parts: Parts) -> trimesh.Trimesh:
    """The boolean union of closed meshes (manifold3d): one watertight mesh."""
    if len(parts) == 1:
        return parts[0].copy()
    return trimesh.boolean.union(parts, engine="manifold")
