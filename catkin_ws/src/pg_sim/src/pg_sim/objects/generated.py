"""Generated object kinds: shapes that real objects have and blocks do not, with dimensions drawn from an id.

Every builder takes a numpy Generator seeded from (kind, id) and returns the object as convex trimesh parts in metres
(the decomposition is exact by construction, so no convex-decomposition run is needed) plus a density in kg/m^3.
The parts have the nominal dimensions (what the camera sees); ``inset`` gives the collision parts, shrunk by Bullet's
collision margin (``HULL_MARGIN``) so that the physical surface is the nominal one too.

Kinds and their dimension ranges (m):
- ``thin``: flat objects 3-12 mm tall: knife (blade 0.10-0.16 x 0.015-0.028, 3-6 mm, with a 8-12 mm handle),
  spatula (handle and a 0.04-0.07 wide blade), scissors-like (two crossed 4-8 mm blades), card (0.05-0.09, 3-6 mm).
- ``rod``: pens and rods lying down: round or hexagonal, diameter 8-16 mm, length 0.09-0.16.
- ``rolling``: sphere (d 0.03-0.06), can or cylinder lying down (d 0.035-0.065, length 0.06-0.12),
  fruit-like ellipsoid (semi-axes 0.018-0.04).
- ``concave``: cup (d 0.05-0.08, h 0.05-0.10), bowl (d 0.08-0.12, h 0.03-0.05), mug with a handle.
- ``small``: cube, cylinder, sphere or ellipsoid under 25 mm in every direction (12-24 mm).
- ``wide``: wider than the open jaw (0.085 m) in one direction: bars and boxes 0.09-0.14 long, 0.025-0.06 across.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
import trimesh
from scipy.spatial import ConvexHull, HalfspaceIntersection

from pg_sim.scenes.shapes import HULL_MARGIN

Parts = list[trimesh.Trimesh]
Builder = Callable[[np.random.Generator], tuple[Parts, float]]

STEEL, PLASTIC, WOOD, CERAMIC, FRUIT = 7800.0, 1000.0, 600.0, 2000.0, 900.0  # kg/m^3
_MIN = 5e-4  # m: smallest nominal dimension of a part


def _box(x: float, y: float, z: float, at: tuple[float, float, float] = (0.0, 0.0, 0.0), yaw: float = 0.0,
         tilt: tuple[str, float] | None = None) -> trimesh.Trimesh:
    """A box of nominal extents (x, y, z), turned by ``yaw`` about z (and ``tilt`` (axis, angle) before), at ``at``."""
    m = trimesh.creation.box(extents=[max(x, _MIN), max(y, _MIN), max(z, _MIN)])
    if tilt is not None:
        axis = {"x": [1, 0, 0], "y": [0, 1, 0]}[tilt[0]]
        m.apply_transform(trimesh.transformations.rotation_matrix(tilt[1], axis))
    m.apply_transform(trimesh.transformations.rotation_matrix(yaw, [0, 0, 1]))
    m.apply_translation(at)
    return m


def _cylinder(radius: float, length: float, sections: int = 20, lying: bool = False,
              at: tuple[float, float, float] = (0.0, 0.0, 0.0)) -> trimesh.Trimesh:
    """A cylinder (axis z, or x when ``lying``) of nominal radius and length."""
    m = trimesh.creation.cylinder(radius=max(radius, _MIN), height=max(length, _MIN), sections=sections)
    if lying:
        m.apply_transform(trimesh.transformations.rotation_matrix(math.pi / 2, [0, 1, 0]))
    m.apply_translation(at)
    return m


def _ellipsoid(a: float, b: float, c: float) -> trimesh.Trimesh:
    m = trimesh.creation.icosphere(subdivisions=2, radius=1.0)
    m.apply_scale([max(a, _MIN), max(b, _MIN), max(c, _MIN)])
    return m


def inset(part: trimesh.Trimesh, margin: float = HULL_MARGIN) -> trimesh.Trimesh:
    """The convex ``part`` with every face moved inwards by ``margin`` (m): Bullet pads a hull by its collision
    margin, so the inset hull collides at the nominal surface. Parts thinner than 2.5 margins shrink about their
    centre to 40 % in that direction instead (Bullet keeps them at least that thick anyway)."""
    hull = ConvexHull(part.vertices)
    eq = hull.equations.copy()  # rows (n, d) with n . x + d <= 0 inside; moving inwards: d += margin
    eq[:, 3] += margin
    centre = part.vertices.mean(axis=0)
    try:
        if np.any(eq[:, :3] @ centre + eq[:, 3] >= -1e-9):
            raise ValueError("too thin to inset")
        pts = HalfspaceIntersection(eq, centre).intersections
        return trimesh.convex.convex_hull(pts)
    except Exception:  # noqa: BLE001 - scipy raises QhullError/ValueError for degenerate thin parts
        ext = part.extents
        factor = np.maximum(0.4, (ext - 2 * margin) / np.maximum(ext, 1e-9))
        out = part.copy()
        out.apply_translation(-centre)
        out.vertices = out.vertices * factor + centre
        return out


def _u(rng: np.random.Generator, lo: float, hi: float) -> float:
    return float(rng.uniform(lo, hi))


# ------------------------------------------------------------------------------------------------------------ kinds
def thin(rng: np.random.Generator) -> tuple[Parts, float]:
    form = int(rng.integers(4))
    t = _u(rng, 0.003, 0.006)
    if form == 0:  # knife: blade plus a thicker handle, both lying flat
        blade, width, handle = _u(rng, 0.10, 0.16), _u(rng, 0.015, 0.028), _u(rng, 0.07, 0.10)
        th = _u(rng, 0.008, 0.012)
        return [_box(blade, width, t, (blade / 2, 0.0, -th / 2 + t / 2)),
                _box(handle, 0.02, th, (-handle / 2, 0.0, 0.0))], STEEL * 0.5
    if form == 1:  # spatula: narrow handle, wide blade
        handle, blade, width = _u(rng, 0.09, 0.13), _u(rng, 0.05, 0.08), _u(rng, 0.04, 0.07)
        return [_box(handle, 0.018, t, (-handle / 2, 0.0, 0.0)), _box(blade, width, t, (blade / 2, 0.0, 0.0))], PLASTIC
    if form == 2:  # scissors-like: two blades crossed at a small angle, one on the other
        length, width, angle = _u(rng, 0.12, 0.16), _u(rng, 0.012, 0.02), _u(rng, 0.25, 0.6)
        t = _u(rng, 0.004, 0.006)
        return [_box(length, width, t, (0.0, 0.0, -t / 2), yaw=angle / 2),
                _box(length, width, t, (0.0, 0.0, t / 2), yaw=-angle / 2)], STEEL * 0.5
    side = _u(rng, 0.05, 0.09)  # card / coaster
    return [_box(side, _u(rng, 0.6, 1.0) * side, t)], WOOD


def rod(rng: np.random.Generator) -> tuple[Parts, float]:
    radius, length = _u(rng, 0.004, 0.008), _u(rng, 0.09, 0.16)
    sections = 6 if rng.random() < 0.4 else 20  # hexagonal pencil or round pen
    return [_cylinder(radius, length, sections, lying=True)], PLASTIC


def rolling(rng: np.random.Generator) -> tuple[Parts, float]:
    form = int(rng.integers(3))
    if form == 0:
        r = _u(rng, 0.015, 0.03)
        return [_ellipsoid(r, r, r)], PLASTIC * 0.5
    if form == 1:  # can or cylinder lying on its side
        return [_cylinder(_u(rng, 0.0175, 0.0325), _u(rng, 0.06, 0.12), lying=True)], PLASTIC * 0.5
    a = _u(rng, 0.022, 0.04)  # fruit-like ellipsoid
    return [_ellipsoid(a, _u(rng, 0.7, 1.0) * a, _u(rng, 0.45, 0.8) * a)], FRUIT


def _ring(r_out: float, height: float, wall: float, z0: float, segments: int, flare: float = 0.0) -> Parts:
    """A ring of ``segments`` wall boxes standing on z0 (optionally leaning out by ``flare`` rad, a bowl's wall)."""
    parts = []
    half_w = r_out * math.tan(math.pi / segments)
    for k in range(segments):
        t = 2 * math.pi * (k + 0.5) / segments
        lean = math.sin(flare) * height / 2
        r = r_out - wall / 2 + lean
        box = _box(wall, 2 * half_w + wall, height, (0.0, 0.0, 0.0), tilt=("y", flare) if flare else None)
        box.apply_transform(trimesh.transformations.rotation_matrix(t, [0, 0, 1]))
        box.apply_translation([r * math.cos(t), r * math.sin(t), z0 + height / 2])
        parts.append(box)
    return parts


def concave(rng: np.random.Generator) -> tuple[Parts, float]:
    form = int(rng.integers(3))
    wall, bottom = _u(rng, 0.004, 0.006), 0.006
    if form == 1:  # bowl: wide, low, flared wall
        d, h = _u(rng, 0.08, 0.12), _u(rng, 0.03, 0.05)
        base = d * 0.55
        return [_cylinder(base / 2, bottom, at=(0, 0, bottom / 2)),
                *_ring(base / 2 + 0.006, h, wall, bottom * 0.5, 10, flare=math.radians(35))], CERAMIC * 0.5
    d, h = _u(rng, 0.05, 0.08), _u(rng, 0.05, 0.10)
    parts = [_cylinder(d / 2 - wall, bottom, at=(0, 0, bottom / 2)), *_ring(d / 2, h, wall, 0.0, 10)]
    if form == 2:  # mug: a handle of three bars on +x
        reach, bar = _u(rng, 0.02, 0.03), 0.007
        x0, x1 = d / 2 - wall / 2, d / 2 + reach
        parts += [_box(bar, bar, 0.6 * h, (x1 - bar / 2, 0.0, h / 2)),
                  _box(x1 - x0, bar, bar, ((x0 + x1) / 2, 0.0, 0.8 * h - bar / 2)),
                  _box(x1 - x0, bar, bar, ((x0 + x1) / 2, 0.0, 0.2 * h + bar / 2))]
    return parts, CERAMIC * 0.5


def small(rng: np.random.Generator) -> tuple[Parts, float]:
    form, s = int(rng.integers(4)), _u(rng, 0.012, 0.024)
    if form == 0:
        return [_box(s, _u(rng, 0.6, 1.0) * s, _u(rng, 0.6, 1.0) * s)], WOOD
    if form == 1:
        return [_cylinder(s / 2, _u(rng, 0.5, 1.0) * s)], PLASTIC
    if form == 2:
        return [_ellipsoid(s / 2, s / 2, s / 2)], PLASTIC
    return [_ellipsoid(s / 2, _u(rng, 0.5, 0.9) * s / 2, _u(rng, 0.4, 0.8) * s / 2)], FRUIT


def wide(rng: np.random.Generator) -> tuple[Parts, float]:
    length, across = _u(rng, 0.09, 0.14), _u(rng, 0.025, 0.06)
    if rng.random() < 0.5:
        return [_box(length, across, _u(rng, 0.02, 0.05))], WOOD
    return [_cylinder(across / 2, length, lying=True)], PLASTIC * 0.5


BUILDERS: dict[str, Builder] = {
    "thin": thin, "rod": rod, "rolling": rolling, "concave": concave, "small": small, "wide": wide,
}


def build(kind: str, rng: np.random.Generator) -> tuple[Parts, float]:
    """Parts (recentred on their common bounding-box centre) and density (kg/m^3) of one object of ``kind``."""
    parts, density = BUILDERS[kind](rng)
    lo = np.min([p.bounds[0] for p in parts], axis=0)
    hi = np.max([p.bounds[1] for p in parts], axis=0)
    centre = (lo + hi) / 2.0
    for p in parts:
        p.apply_translation(-centre)
    return parts, density
