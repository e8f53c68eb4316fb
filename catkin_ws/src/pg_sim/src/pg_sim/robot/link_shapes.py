"""The primitive shapes a generated link is made of (cylinders along a segment, boxes) and their composite inertia.

Units: metres, kilograms; every pose is in the owning link's frame. Used by pg_sim.robot.urdf_builder.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from pg_core.kinematics import matrix_rpy, rpy_matrix


@dataclass(frozen=True)
class Shape:
    """One collision/visual primitive in a link frame: a cylinder (radius, length) along its local z, or a box."""

    kind: str  # "cylinder" | "box"
    size: tuple[float, ...]  # cylinder: (radius, length); box: (x, y, z)
    xyz: tuple[float, float, float]
    rpy: tuple[float, float, float]
    material: str

    @property
    def volume(self) -> float:
        if self.kind == "cylinder":
            return math.pi * self.size[0] ** 2 * self.size[1]
        return float(np.prod(self.size))

    def inertia(self, mass: float) -> np.ndarray:
        """3x3 inertia (kg m^2) of a solid shape of ``mass`` about its centre, in its own frame."""
        if self.kind == "cylinder":
            r, h = self.size
            ixx = mass * (3.0 * r * r + h * h) / 12.0
            return np.diag([ixx, ixx, 0.5 * mass * r * r])
        x, y, z = self.size
        return np.diag([y * y + z * z, x * x + z * z, x * x + y * y]) * mass / 12.0


def segment(p0: Sequence[float], p1: Sequence[float], radius: float, material: str) -> Shape:
    """A solid cylinder of ``radius`` from point ``p0`` to point ``p1`` (link frame, m)."""
    a, b = np.asarray(p0, dtype=np.float64), np.asarray(p1, dtype=np.float64)
    axis = b - a
    length = float(np.linalg.norm(axis))
    if length <= 0.0:
        raise ValueError("segment: zero length")
    u = axis / length
    # rotation taking z onto u: pitch about y then yaw about z (rpy = (0, pitch, yaw)), exact for any u.
    pitch = math.atan2(math.hypot(u[0], u[1]), u[2])
    yaw = math.atan2(u[1], u[0]) if math.hypot(u[0], u[1]) > 1e-12 else 0.0
    mid = 0.5 * (a + b)
    return Shape("cylinder", (radius, length), tuple(mid.tolist()), (0.0, pitch, yaw), material)


def box(size: Sequence[float], xyz: Sequence[float], material: str, rpy: Sequence[float] = (0.0, 0.0, 0.0)) -> Shape:
    return Shape("box", tuple(float(s) for s in size), tuple(float(v) for v in xyz), tuple(rpy), material)


def composite_inertia(shapes: Sequence[Shape], mass: float) -> tuple[np.ndarray, np.ndarray]:
    """COM (3,) and inertia tensor (3x3, about the COM, link axes) of solid ``shapes`` sharing ``mass`` by volume."""
    vols = np.array([s.volume for s in shapes])
    masses = mass * vols / vols.sum()
    com = sum(m * np.asarray(s.xyz) for m, s in zip(masses, shapes, strict=True)) / mass
    inertia = np.zeros((3, 3))
    for m, s in zip(masses, shapes, strict=True):
        rot = rpy_matrix(s.rpy)
        c = np.asarray(s.xyz) - com
        inertia += rot @ s.inertia(m) @ rot.T + m * (c @ c * np.eye(3) - np.outer(c, c))
    return com, inertia


def principal_axes(inertia: np.ndarray) -> tuple[np.ndarray, tuple[float, float, float]]:
    """Principal moments (3,) and the rpy of a proper rotation whose columns are the principal axes."""
    moments, vecs = np.linalg.eigh(0.5 * (inertia + inertia.T))
    # keep the axes as close to the link axes as possible (stable, readable output)
    order = [int(np.argmax(np.abs(vecs[i, :]))) for i in range(3)]
    if sorted(order) == [0, 1, 2]:
        vecs, moments = vecs[:, order], moments[order]
    for i in range(3):
        if vecs[i, i] < 0.0:
            vecs[:, i] = -vecs[:, i]
    if np.linalg.det(vecs) < 0.0:
        vecs[:, 2] = -vecs[:, 2]
    rpy = matrix_rpy(vecs)
    return moments, rpy


# ----------------------------------------------------------------------------------------------------------- XML
