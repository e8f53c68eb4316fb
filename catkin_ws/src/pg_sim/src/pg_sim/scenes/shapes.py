"""Object shapes for the PyBullet world: the paper's blocks, household-like objects and arbitrary .obj meshes.

Every shape is generated here (no reference mesh is ever loaded). ``REGISTRY`` maps a shape name to a builder; a builder
is called as ``builder(client, size)`` and returns ``(collision_shape_id, visual_shape_id, default_mass_kg)``.

Conventions (DESIGN.md section 6):
- ``size`` is always the (x, y, z) extent in metres of the shape's bounding box in its local frame; None = default.
- The local frame is the bounding-box centre; axes as in the paper's block meshes: the triangle is a triangular cross
  section in x-y (apex at -x) extruded along z; the arch (``concave.obj``) is 0.09 x 0.045 x 0.045 with its semicircular
  notch opening at +y; the half-cylinder's flat side faces +y; the cylinder's axis is z.
- Household shapes rest in their natural pose at identity orientation (the milk box lies, the mug stands).
- Concave shapes (arch, mug) are compounds of convex parts, never a convex hull.

Convex mesh parts are inset by Bullet's collision margin (``HULL_MARGIN``) so that the physical surface is the nominal
one; ``p.getAABB`` reports such parts ``HULL_MARGIN`` larger on each side (Bullet pads hull AABBs by twice the margin).
Generated part files and V-HACD decompositions are cached under ``cache_dir()``.
"""

from __future__ import annotations

import hashlib
import math
import os
import tempfile
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

Vec3 = tuple[float, float, float]
Quat = tuple[float, float, float, float]
Polygon = tuple[tuple[float, float], ...]

MAX_PARTS = 16  # PyBullet's MAX_COMPOUND_COLLISION_SHAPES: parts per createCollisionShapeArray
HULL_MARGIN = 0.001  # m, Bullet's default collision margin of convex hull shapes in PyBullet
MESH_DENSITY = 600.0  # kg/m^3 for `mesh` objects (mass clipped to MESH_MASS_RANGE)
MESH_MASS_RANGE = (0.05, 0.3)
CONVEX_VOLUME_RATIO = 0.97  # a mesh whose volume is below this fraction of its hull's is decomposed with V-HACD
_IDENTITY: Quat = (0.0, 0.0, 0.0, 1.0)


def cache_dir(kind: str) -> Path:
    """Writable cache folder ``$PUSHGRASP_CACHE/<kind>`` (default ``~/.cache/pushgrasp/<kind>``), made if missing."""
    root = os.environ.get("PUSHGRASP_CACHE") or os.path.join(
        os.environ.get("XDG_CACHE_HOME") or os.path.expanduser("~/.cache"), "pushgrasp"
    )
    for base in (Path(root), Path(tempfile.gettempdir()) / "pushgrasp-cache"):
        path = base / kind
        try:
            path.mkdir(parents=True, exist_ok=True)
            if os.access(path, os.W_OK):
                return path
        except OSError:
            continue
    raise OSError(f"no writable cache directory for {kind!r} (tried {root})")


def _atomic_write(path: Path, text: str) -> None:
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    tmp.write_text(text)
    os.replace(tmp, path)


# ---------------------------------------------------------------------------------------------------------------- parts
@dataclass(frozen=True)
class Part:
    """One convex piece of a shape, posed in the shape's local frame.

    kind "box": dims = half extents; "cylinder": dims = (radius, height) along the part's z; "prism": ``polygon``
    (convex, counter-clockwise, metres) in the part's x-y plane extruded over z in [-dims[0], dims[0]].
    """

    kind: str
    dims: tuple[float, ...]
    pos: Vec3 = (0.0, 0.0, 0.0)
    quat: Quat = _IDENTITY
    polygon: Polygon = field(default=())

    def local_points(self) -> np.ndarray:
        """Corner points (N, 3) of the part's own bounding geometry, in the part frame."""
        if self.kind == "prism":
            h = self.dims[0]
            return np.array([(x, y, z) for z in (-h, h) for x, y in self.polygon])
        hx, hy, hz = self.dims if self.kind == "box" else (self.dims[0], self.dims[0], self.dims[1] / 2.0)
        return np.array([(sx * hx, sy * hy, sz * hz) for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)])

    def points(self) -> np.ndarray:
        """Corner points (N, 3) in the shape frame."""
        rot = Rotation.from_quat(self.quat).as_matrix()  # quat (x, y, z, w), as PyBullet's
        return self.local_points() @ rot.T + np.asarray(self.pos)


def _bounds(parts: Sequence[Part]) -> tuple[np.ndarray, np.ndarray]:
    pts = np.vstack([part.points() for part in parts])
    return pts.min(axis=0), pts.max(axis=0)


def _recentre(parts: Sequence[Part]) -> list[Part]:
    """Shift every part so that the bounding-box centre of the whole shape is the origin."""
    lo, hi = _bounds(parts)
    c = (lo + hi) / 2.0
    return [
        Part(q.kind, q.dims, (q.pos[0] - c[0], q.pos[1] - c[1], q.pos[2] - c[2]), q.quat, q.polygon) for q in parts
    ]


def _inset_polygon(poly: Polygon, m: float) -> Polygon:
    """Offset a convex counter-clockwise polygon inwards by ``m`` (each edge moved along its inner normal)."""
    pts = np.asarray(poly, dtype=np.float64)
    n = len(pts)
    lines = []
    for i in range(n):
        a, b = pts[i], pts[(i + 1) % n]
        d = (b - a) / np.linalg.norm(b - a)
        normal = np.array([-d[1], d[0]])  # inner normal for a counter-clockwise polygon
        lines.append((a + m * normal, d))
    out = []
    for i in range(n):
        (p0, d0), (p1, d1) = lines[i - 1], lines[i]
        mat = np.column_stack([d0, -d1])
        if abs(np.linalg.det(mat)) < 1e-12:  # collinear neighbours: keep the shifted point
            out.append(tuple(p1))
            continue
        t = np.linalg.solve(mat, p1 - p0)
        out.append(tuple(p0 + t[0] * d0))
    return tuple((float(x), float(y)) for x, y in out)


def _prism_obj(poly: Polygon, half_z: float, name: str = "part") -> str:
    """Wavefront OBJ text of a closed prism with flat normals (one object)."""
    n = len(poly)
    lines = [f"o {name}"]
    lines += [f"v {x:.9f} {y:.9f} {z:.9f}" for z in (-half_z, half_z) for x, y in poly]
    normals = ["vn 0 0 -1", "vn 0 0 1"]
    faces = [
        "f " + " ".join(f"{i + 1}//1" for i in reversed(range(n))),
        "f " + " ".join(f"{n + i + 1}//2" for i in range(n)),
    ]
    for i in range(n):
        (x0, y0), (x1, y1) = poly[i], poly[(i + 1) % n]
        length = math.hypot(x1 - x0, y1 - y0)
        normals.append(f"vn {(y1 - y0) / length:.9f} {-(x1 - x0) / length:.9f} 0")
        k = len(normals)
        j = (i + 1) % n
        faces.append(f"f {i + 1}//{k} {j + 1}//{k} {n + j + 1}//{k} {n + i + 1}//{k}")
    return "\n".join(lines + normals + faces) + "\n"


def _prism_file(poly: Polygon, half_z: float) -> str:
    text = _prism_obj(poly, half_z)
    path = cache_dir("shapes") / f"prism_{hashlib.sha1(text.encode()).hexdigest()[:16]}.obj"
    if not path.exists():
        _atomic_write(path, text)
    return str(path)


def _create(client: int, parts: Sequence[Part]) -> tuple[int, int]:
    """Collision and visual shape ids for ``parts`` (compound when several). Raises RuntimeError if PyBullet fails."""
    import pybullet as p  # here, so that scene files and shapes load on a machine without the simulator

    if len(parts) > MAX_PARTS:
        raise ValueError(f"a shape may have at most {MAX_PARTS} parts in PyBullet, got {len(parts)}")
    types, radii, halves, lengths, col_files, vis_files = [], [], [], [], [], []
    for q in parts:
        kind = {"box": p.GEOM_BOX, "cylinder": p.GEOM_CYLINDER, "prism": p.GEOM_MESH}[q.kind]
        types.append(kind)
        radii.append(q.dims[0] if q.kind == "cylinder" else 0.0)
        lengths.append(q.dims[1] if q.kind == "cylinder" else 0.0)
        halves.append(list(q.dims) if q.kind == "box" else [0.0, 0.0, 0.0])
        if q.kind == "prism":
            col_files.append(_prism_file(_inset_polygon(q.polygon, HULL_MARGIN), q.dims[0] - HULL_MARGIN))
            vis_files.append(_prism_file(q.polygon, q.dims[0]))
        else:
            col_files.append("")
            vis_files.append("")
    poses = [list(q.pos) for q in parts]
    quats = [list(q.quat) for q in parts]
    ones = [[1.0, 1.0, 1.0]] * len(parts)
    if len(parts) == 1:
        col = p.createCollisionShape(
            types[0], radius=radii[0], halfExtents=halves[0], height=lengths[0], fileName=col_files[0],
            collisionFramePosition=poses[0], collisionFrameOrientation=quats[0], physicsClientId=client,
        )
        vis = p.createVisualShape(
            types[0], radius=radii[0], halfExtents=halves[0], length=lengths[0], fileName=vis_files[0],
            visualFramePosition=poses[0], visualFrameOrientation=quats[0], physicsClientId=client,
        )
    else:
        col = p.createCollisionShapeArray(
            shapeTypes=types, radii=radii, halfExtents=halves, lengths=lengths, fileNames=col_files, meshScales=ones,
            collisionFramePositions=poses, collisionFrameOrientations=quats, physicsClientId=client,
        )
        vis = p.createVisualShapeArray(
            shapeTypes=types, radii=radii, halfExtents=halves, lengths=lengths, fileNames=vis_files, meshScales=ones,
            visualFramePositions=poses, visualFrameOrientations=quats, physicsClientId=client,
        )
    if col < 0 or vis < 0:
        raise RuntimeError(f"PyBullet could not create shape parts {[q.kind for q in parts]}")
    return col, vis


# ------------------------------------------------------------------------------------------------------ part layouts
def _quat_axis_x() -> Quat:
    """Rotation taking a part's z axis onto the shape's x axis (for lying cylinders)."""
    s = math.sqrt(0.5)
    return (0.0, s, 0.0, s)


def _box(s: Vec3) -> list[Part]:
    return [Part("box", (s[0] / 2, s[1] / 2, s[2] / 2))]


def _cylinder(s: Vec3) -> list[Part]:
    return [Part("cylinder", (min(s[0], s[1]) / 2, s[2]))]


def _triangle(s: Vec3) -> list[Part]:
    a, b = s[0] / 2, s[1] / 2
    return [Part("prism", (s[2] / 2,), polygon=((-a, 0.0), (a, -b), (a, b)))]


def _half_disc(a: float, b: float, segments: int = 16) -> Polygon:
    """Half ellipse (counter-clockwise): flat side at y = +b from x = -a to a, arc down to (0, -b)."""
    angles = np.linspace(math.pi, 2 * math.pi, segments + 1)
    return tuple((float(a * math.cos(t)), float(b + 2 * b * math.sin(t))) for t in angles)


def _half_cylinder(s: Vec3) -> list[Part]:
    return [Part("prism", (s[2] / 2,), polygon=_half_disc(s[0] / 2, s[1] / 2))]


def _arch(s: Vec3, segments: int = 8) -> list[Part]:
    """Block with a semicircular notch (radius 0.0235 m at default size) centred on the +y face, opening at +y."""
    a, b, hz = s[0] / 2, s[1] / 2, s[2] / 2
    r = min(s[0] * 0.0235 / 0.09, s[1] * 0.0235 / 0.045)
    leg = (a - r) / 2
    parts = [Part("box", (leg, b, hz), (-a + leg, 0.0, 0.0)), Part("box", (leg, b, hz), (a - leg, 0.0, 0.0))]
    arc = [(r * math.cos(t), b + r * math.sin(t)) for t in np.linspace(math.pi, 2 * math.pi, segments + 1)]
    for (x0, y0), (x1, y1) in zip(arc[:-1], arc[1:], strict=True):
        poly = ((x0, y0), (x0, -b), (x1, -b), (x1, y1))
        parts.append(Part("prism", (hz,), polygon=tuple((float(x), float(y)) for x, y in poly)))
    return parts


def _soap(s: Vec3) -> list[Part]:
    a, b, c = s[0] / 2, s[1] / 2, 0.22 * min(s[0], s[1])
    poly = ((-a + c, -b), (a - c, -b), (a, -b + c), (a, b - c), (a - c, b), (-a + c, b), (-a, b - c), (-a, -b + c))
    return [Part("prism", (s[2] / 2,), polygon=poly)]


def _bottle(s: Vec3) -> list[Part]:
    """Standing bottle: body cylinder (70 % of the height) and a neck of 45 % of the diameter."""
    r, h = min(s[0], s[1]) / 2, s[2]
    body, neck = 0.7 * h, 0.3 * h
    return [
        Part("cylinder", (r, body), (0.0, 0.0, -h / 2 + body / 2)),
        Part("cylinder", (0.45 * r, neck), (0.0, 0.0, h / 2 - neck / 2)),
    ]


def _mug(s: Vec3, segments: int = 12) -> list[Part]:
    """Standing mug, open at the top: a ring of wall boxes, a bottom disc and a handle on +x."""
    d = s[1]
    handle = s[0] - d
    h, wall, bottom = s[2], 0.006, 0.008
    r_out = d / 2  # the wall is a regular polygon of `segments` boxes whose outer corners lie on this radius
    flat = r_out * math.cos(math.pi / segments)
    half_w = flat * math.tan(math.pi / segments)
    r_mid = flat - wall / 2
    parts = [Part("cylinder", (r_out - wall, bottom), (0.0, 0.0, -h / 2 + bottom / 2))]
    for k in range(segments):
        t = 2 * math.pi * (k + 0.5) / segments
        quat = (0.0, 0.0, math.sin(t / 2), math.cos(t / 2))
        parts.append(Part("box", (wall / 2, half_w, h / 2), (r_mid * math.cos(t), r_mid * math.sin(t), 0.0), quat))
    if handle > 0:
        bar, x0, x_out = 0.006, flat - wall / 2, s[0] - d / 2
        parts += [
            Part("box", (bar / 2, bar / 2, 0.3 * h), (x_out - bar / 2, 0.0, 0.0)),
            Part("box", ((x_out - x0) / 2, bar / 2, bar / 2), ((x0 + x_out) / 2, 0.0, 0.3 * h - bar / 2)),
            Part("box", ((x_out - x0) / 2, bar / 2, bar / 2), ((x0 + x_out) / 2, 0.0, -0.3 * h + bar / 2)),
        ]
    return parts


def _glue(s: Vec3) -> list[Part]:
    """Glue stick lying along x: a body cylinder and a slightly wider cap (the last quarter, at +x)."""
    length, r = s[0], min(s[1], s[2]) / 2
    body, cap = 0.75 * length, 0.25 * length
    q = _quat_axis_x()
    return [
        Part("cylinder", (0.9 * r, body), (-length / 2 + body / 2, 0.0, 0.0), q),
        Part("cylinder", (r, cap), (length / 2 - cap / 2, 0.0, 0.0), q),
    ]


# ------------------------------------------------------------------------------------------------------------ builders
@dataclass(frozen=True)
class ShapeBuilder:
    """A registry entry: ``builder(client, size)`` -> (collision id, visual id, default mass in kg)."""

    name: str
    default_size: Vec3
    default_mass: float
    layout: Callable[[Vec3], list[Part]]
    description: str
    household: bool = False

    def resolve_size(self, size: Sequence[float] | None) -> Vec3:
        """``size`` (3 positive extents in metres) or the default. Raises ValueError for a malformed size."""
        if size is None:
            return self.default_size
        vals = tuple(float(v) for v in size)
        if len(vals) != 3 or not all(v > 0 and math.isfinite(v) for v in vals):
            raise ValueError(f"shape {self.name!r}: size must be 3 positive extents [x, y, z] in metres, got {size!r}")
        return (vals[0], vals[1], vals[2])

    def parts(self, size: Sequence[float] | None = None) -> list[Part]:
        """The convex parts in the local (bounding-box centre) frame."""
        return _recentre(self.layout(self.resolve_size(size)))

    def extents(self, size: Sequence[float] | None = None) -> Vec3:
        """Bounding-box extents (x, y, z) in metres of the generated geometry."""
        lo, hi = _bounds(self.parts(size))
        ext = hi - lo
        return (float(ext[0]), float(ext[1]), float(ext[2]))

    @property
    def uses_hulls(self) -> bool:
        """True when some part is a convex mesh (its AABB is padded by ``HULL_MARGIN`` in PyBullet)."""
        return any(q.kind == "prism" for q in self.layout(self.default_size))

    def __call__(self, client: int, size: Sequence[float] | None = None) -> tuple[int, int, float]:
        col, vis = _create(client, self.parts(size))
        return col, vis, self.default_mass


def _entry(
    name: str, size: Vec3, mass: float, layout: Callable[[Vec3], list[Part]], text: str, household: bool = False
) -> tuple[str, ShapeBuilder]:
    return name, ShapeBuilder(name, size, mass, layout, text, household)


REGISTRY: dict[str, ShapeBuilder] = dict(
    [
        _entry("cube", (0.045, 0.045, 0.045), 0.06, _box, "block 0.045 m"),
        _entry("rect", (0.045, 0.09, 0.045), 0.12, _box, "cuboid block, long along y"),
        _entry("triangle", (0.045, 0.09, 0.045), 0.06, _triangle, "triangular prism, apex at -x, extruded along z"),
        _entry("arch", (0.09, 0.045, 0.045), 0.09, _arch, "concave block, semicircular notch opening at +y"),
        _entry("cylinder", (0.044, 0.044, 0.045), 0.05, _cylinder, "cylinder, axis z"),
        _entry("half_cube", (0.0225, 0.045, 0.045), 0.05, _box, "half block"),
        _entry("half_cylinder", (0.044, 0.022, 0.045), 0.05, _half_cylinder, "half cylinder, flat side at +y"),
        _entry("milk_box", (0.05, 0.075, 0.06), 0.2, _box, "lying milk carton (household target)", True),
        _entry("bottle", (0.045, 0.045, 0.10), 0.15, _bottle, "standing bottle with a neck", True),
        _entry("can", (0.055, 0.055, 0.075), 0.15, _cylinder, "standing can", True),
        _entry("mug", (0.07, 0.055, 0.065), 0.2, _mug, "standing mug, handle at +x", True),
        _entry("soap", (0.07, 0.045, 0.025), 0.1, _soap, "soap bar", True),
        _entry("small_box", (0.09, 0.035, 0.03), 0.08, _box, "lying toothpaste-like box", True),
        _entry("glue", (0.08, 0.028, 0.028), 0.05, _glue, "glue stick lying along x", True),
    ]
)


def known_shapes() -> list[str]:
    """Every shape name a scene may use: the registry plus ``mesh``."""
    return sorted([*REGISTRY, "mesh"])


def get_builder(name: str) -> ShapeBuilder:
    """The registry entry for ``name``. Raises ValueError listing the known shapes."""
    try:
        return REGISTRY[name]
    except KeyError:
        raise ValueError(f"unknown shape {name!r}; known shapes: {', '.join(known_shapes())}") from None
