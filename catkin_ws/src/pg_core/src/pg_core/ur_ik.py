"""Closed-form inverse kinematics of a UR arm (standard DH, spherical-offset wrist), numpy only.

Why hand-written: PyBullet's damped-least-squares IK is local and, with null-space rest poses, leaves mm-level
residuals; the UR geometry has an exact solution with up to 8 branches (Hawkins, "Analytic Inverse Kinematics for
the Universal Robots UR-5/UR-10 Arms", 2013), which lets us pick the branch closest to the current joints.
Every candidate is verified with the forward kinematics before it is returned.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from pg_core.kinematics import dh_fk, dh_transform


def _wrap(q: float) -> float:
    return float((q + np.pi) % (2 * np.pi) - np.pi)


def ik_all(t: np.ndarray, d: Sequence[float], a: Sequence[float], alpha: Sequence[float],
           tol: float = 1e-6, branch: tuple[int, int, int] | None = None) -> list[np.ndarray]:
    """All joint solutions (rad, each in (-pi, pi]) with dh_fk(q) == t (base_link <- tool0, metres).

    `branch` = (shoulder, wrist, elbow) signs in {+1, -1} keeps only that one of the 8 solution branches.
    """
    a2, a3, d4, d6 = a[1], a[2], d[3], d[5]
    p05 = t @ np.array([0.0, 0.0, -d6, 1.0])
    r = np.hypot(p05[0], p05[1])
    if r < abs(d4) + 1e-9:
        return []
    sols = []
    for s1 in (1.0, -1.0):
        if branch and s1 != branch[0]:
            continue
        q1 = np.arctan2(p05[1], p05[0]) + s1 * np.arccos(d4 / r) + np.pi / 2
        c1, n1 = np.cos(q1), np.sin(q1)
        arg5 = (t[0, 3] * n1 - t[1, 3] * c1 - d4) / d6
        if abs(arg5) > 1.0 + 1e-9:
            continue
        for s5 in (1.0, -1.0):
            if branch and s5 != branch[1]:
                continue
            q5 = s5 * np.arccos(np.clip(arg5, -1.0, 1.0))
            n5 = np.sin(q5)
            if abs(n5) < 1e-9:  # wrist singularity: q6 is free; keep 0
                q6 = 0.0
            else:
                q6 = np.arctan2((-t[0, 1] * n1 + t[1, 1] * c1) / n5, (t[0, 0] * n1 - t[1, 0] * c1) / n5)
            t01 = dh_transform(q1, d[0], a[0], alpha[0])
            t45 = dh_transform(q5, d[4], a[4], alpha[4])
            t56 = dh_transform(q6, d[5], a[5], alpha[5])
            t14 = np.linalg.inv(t01) @ t @ np.linalg.inv(t45 @ t56)
            p13 = t14 @ np.array([0.0, -d4, 0.0, 1.0])  # frame 3 origin: z3 = -y4 since alpha4 = pi/2
            px, py = p13[0], p13[1]
            dist2 = px * px + py * py
            arg3 = (dist2 - a2 * a2 - a3 * a3) / (2 * a2 * a3)
            if abs(arg3) > 1.0 + 1e-9:
                continue
            for s3 in (1.0, -1.0):
                if branch and s3 != branch[2]:
                    continue
                q3 = s3 * np.arccos(np.clip(arg3, -1.0, 1.0))
                q2 = np.arctan2(py, px) - np.arctan2(a3 * np.sin(q3), a2 + a3 * np.cos(q3))  # planar 2-link
                t13 = dh_transform(q2, d[1], a[1], alpha[1]) @ dh_transform(q3, d[2], a[2], alpha[2])
                t34 = np.linalg.inv(t13) @ t14
                q4 = np.arctan2(t34[1, 0], t34[0, 0])
                q = np.array([_wrap(v) for v in (q1, q2, q3, q4, q5, q6)])
                if np.abs(dh_fk(q, d, a, alpha) - t).max() < tol:
                    sols.append(q)
    return sols


def closest(sols: list[np.ndarray], seed: np.ndarray, lower: np.ndarray, upper: np.ndarray) -> np.ndarray | None:
    """The solution nearest `seed`, each joint shifted by 2 pi multiples within [lower, upper]; None if none fits."""
    best, best_cost = None, np.inf
    for q in sols:
        shifted = q + 2 * np.pi * np.round((seed - q) / (2 * np.pi))
        for k in range(6):  # the nearest 2 pi shift may leave the limits: try the other side
            if shifted[k] > upper[k]:
                shifted[k] -= 2 * np.pi
            elif shifted[k] < lower[k]:
                shifted[k] += 2 * np.pi
        if np.any(shifted < lower - 1e-9) or np.any(shifted > upper + 1e-9):
            continue
        cost = float(np.abs(shifted - seed).max() * 10 + np.abs(shifted - seed).sum())
        if cost < best_cost:
            best, best_cost = shifted, cost
    return best
