"""Arbitrary .obj meshes as PyBullet objects: reading, convexity test, cached V-HACD decomposition, shapes.

The local frame of a mesh object is its (scaled) bounding-box centre. A mesh ``X.obj`` collides as its companion
``X.collision.obj`` when that file exists (convex parts, one group each, e.g. inset by Bullet's margin); otherwise
concave meshes are decomposed once with V-HACD and cached (see pg_sim.scenes.shapes.cache_dir) and convex ones load
directly.
"""

from __future__ import annotations

import contextlib
import ctypes
import hashlib
import os
import sys
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from pg_sim.scenes.shapes import CONVEX_VOLUME_RATIO, MESH_DENSITY, MESH_MASS_RANGE, Vec3, cache_dir


@dataclass(frozen=True)
class ObjMesh:
    """Vertices (N, 3) in metres, polygon faces (0-based indices) and the number of objects/groups in the file."""

    vertices: np.ndarray
    faces: tuple[tuple[int, ...], ...]
    objects: int


def load_obj(path: str | os.PathLike[str]) -> ObjMesh:
    """Read the geometry of a Wavefront .obj file. Raises FileNotFoundError, or ValueError for a file without faces
    or with a non-finite vertex (nan, inf)."""
    verts: list[tuple[float, float, float]] = []
    faces: list[tuple[int, ...]] = []
    objects = 0
    with open(path, encoding="utf-8", errors="replace") as fh:
        for lineno, line in enumerate(fh, 1):
            tok = line.split()
            if not tok:
                continue
            try:
                if tok[0] == "v":
                    verts.append((float(tok[1]), float(tok[2]), float(tok[3])))
                elif tok[0] == "f":
                    idx = [int(t.split("/")[0]) for t in tok[1:]]
                    faces.append(tuple(i - 1 if i > 0 else len(verts) + i for i in idx))
                elif tok[0] in ("o", "g"):
                    objects += 1
            except (IndexError, ValueError):
                raise ValueError(f"{path}:{lineno}: malformed OBJ line {line.strip()!r}") from None
    if not faces or not verts:
        raise ValueError(f"{path}: OBJ file has no faces")
    if any(i < 0 or i >= len(verts) for f in faces for i in f):
        raise ValueError(f"{path}: OBJ face index out of range")
    vertices = np.asarray(verts, dtype=np.float64)
    if not np.isfinite(vertices).all():
        bad = int((~np.isfinite(vertices)).any(axis=1).sum())
        raise ValueError(f"{path}: {bad} of {len(vertices)} OBJ vertices are not finite")
    return ObjMesh(vertices, tuple(faces), max(objects, 1))


def mesh_volume(mesh: ObjMesh) -> float:
    """Enclosed volume (m^3) of a closed, consistently oriented mesh (divergence theorem, faces fanned)."""
    v = mesh.vertices
    total = 0.0
    for f in mesh.faces:
        for k in range(1, len(f) - 1):
            total += float(np.dot(v[f[0]], np.cross(v[f[k]], v[f[k + 1]])))
    return abs(total) / 6.0


def is_convex(mesh: ObjMesh) -> bool:
    """True when the mesh fills at least ``CONVEX_VOLUME_RATIO`` of its convex hull's volume."""
    from scipy.spatial import ConvexHull

    hull_volume = ConvexHull(mesh.vertices).volume
    return hull_volume > 0 and mesh_volume(mesh) >= CONVEX_VOLUME_RATIO * hull_volume


def _scale3(scale: float | Sequence[float]) -> Vec3:
    vals = (float(scale),) * 3 if isinstance(scale, int | float) else tuple(float(s) for s in scale)
    if len(vals) != 3 or not all(v > 0 for v in vals):
        raise ValueError(f"mesh scale must be a positive number or 3 positive factors, got {scale!r}")
    return (vals[0], vals[1], vals[2])


@contextlib.contextmanager
def _stdout_to(path: Path) -> Iterator[None]:
    """Send the process's file descriptor 1 (C and Python stdout) to the end of `path` inside the block. Process-wide:
    other threads' stdout goes there too meanwhile."""
    sys.stdout.flush()
    libc = ctypes.CDLL(None)
    libc.fflush(None)
    saved = os.dup(1)
    try:
        with open(path, "ab") as f:
            os.dup2(f.fileno(), 1)
        yield
    finally:
        libc.fflush(None)
        os.dup2(saved, 1)
        os.close(saved)


def decomposed_obj(path: str | os.PathLike[str], resolution: int = 100000) -> Path:
    """V-HACD convex decomposition of ``path``, computed once and cached as ``<cache>/vhacd/<sha1>.obj``."""
    data = Path(path).read_bytes()
    key = hashlib.sha1(data + f"|vhacd|resolution={resolution}".encode()).hexdigest()
    out = cache_dir("vhacd") / f"{key}.obj"
    if not out.exists():
        tmp = out.with_name(f".{key}.{os.getpid()}.obj")
        log = out.with_name(f".{key}.{os.getpid()}.log")
        import pybullet as p  # here, so that scene files load on a machine without the simulator

        with _stdout_to(log):  # V-HACD prints its parameters and progress (pages) to the C stdout
            p.vhacd(str(path), str(tmp), str(log), resolution=resolution)
        if not tmp.exists() or tmp.stat().st_size == 0:
            raise RuntimeError(f"V-HACD failed to decompose {path} (its output: {log})")
        os.replace(tmp, out)
        log.unlink(missing_ok=True)
    return out


def mesh_extents(path: str | os.PathLike[str], scale: float | Sequence[float] = 1.0) -> Vec3:
    """Bounding-box extents (m) of an .obj mesh after scaling."""
    v = load_obj(path).vertices * np.asarray(_scale3(scale))
    ext = v.max(axis=0) - v.min(axis=0)
    return (float(ext[0]), float(ext[1]), float(ext[2]))


def collision_file(path: str | os.PathLike[str]) -> Path:
    """The collision companion of a mesh file: ``X.obj`` -> ``X.collision.obj`` (used when it exists)."""
    path = Path(path)
    return path.with_name(f"{path.stem}.collision{path.suffix}")


def build_mesh(
    client: int, path: str | os.PathLike[str], scale: float | Sequence[float] = 1.0
) -> tuple[int, int, float]:
    """Collision/visual shapes for an .obj file, local frame = its (scaled) bounding-box centre.

    Convex meshes load directly; others are decomposed once with V-HACD (cached) and load as a compound of hulls.
    Returns (collision id, visual id, mass in kg from the volume at ``MESH_DENSITY``). Raises FileNotFoundError,
    ValueError (malformed file or scale) or RuntimeError (PyBullet/V-HACD failure).
    """
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"mesh file not found: {path}")
    mesh = load_obj(path)
    s = np.asarray(_scale3(scale))
    centre = -(mesh.vertices.min(axis=0) + mesh.vertices.max(axis=0)) / 2.0 * s
    if collision_file(path).is_file():
        col_file = collision_file(path)
    else:
        convex = mesh.objects > 1 or is_convex(mesh)  # several objects = already decomposed into convex pieces
        col_file = path if convex else decomposed_obj(path)
    import pybullet as p  # here, so that scene files load on a machine without the simulator

    col = p.createCollisionShape(
        p.GEOM_MESH, fileName=str(col_file), meshScale=list(s), collisionFramePosition=list(centre),
        physicsClientId=client,
    )
    vis = p.createVisualShape(
        p.GEOM_MESH, fileName=str(path), meshScale=list(s), visualFramePosition=list(centre), physicsClientId=client
    )
    if col < 0 or vis < 0:
        raise RuntimeError(f"PyBullet could not load mesh {path}")
    volume = mesh_volume(mesh) * float(np.prod(s))
    mass = float(np.clip(volume * MESH_DENSITY, *MESH_MASS_RANGE))
    return col, vis, mass
