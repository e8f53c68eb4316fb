"""Closed-form kinematics of the UR5e arms (numpy only, no pybullet, no ROS).

Conventions (DESIGN.md section 3):
- Standard Denavit-Hartenberg: T_i = Rz(q_i) Tz(d_i) Tx(a_i) Rx(alpha_i), i = 1..6.
  Lengths in metres, angles in radians.
- ``<arm>_base_link`` IS DH frame 0 and ``<arm>_tool0`` IS DH frame 6 (the URDF built by
  :mod:`pg_sim.robot.urdf_builder` places every link frame on its DH frame, so the URDF zero
  configuration is the DH zero configuration).
- 4x4 homogeneous transforms ``T_a_b`` map points from frame b into frame a (``a <- b``).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np


def rpy_matrix(rpy: Sequence[float]) -> np.ndarray:
    """3x3 rotation of URDF/ROS fixed-axis roll-pitch-yaw (rad): R = Rz(yaw) Ry(pitch) Rx(roll)."""
    r, p, y = (float(v) for v in rpy)
    cr, sr, cp, sp, cy, sy = np.cos(r), np.sin(r), np.cos(p), np.sin(p), np.cos(y), np.sin(y)
    return np.array(
        [
            [cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
            [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
            [-sp, cp * sr, cp * cr],
        ]
    )


def matrix_rpy(rot: np.ndarray) -> tuple[float, float, float]:
    """URDF roll-pitch-yaw (rad) of a 3x3 rotation; inverse of :func:`rpy_matrix` (pitch in [-pi/2, pi/2])."""
    rot = np.asarray(rot, dtype=np.float64)
    pitch = float(np.arctan2(-rot[2, 0], np.hypot(rot[0, 0], rot[1, 0])))
    if np.hypot(rot[0, 0], rot[1, 0]) < 1e-12:  # gimbal lock: put everything into roll
        return float(np.arctan2(-rot[1, 2], rot[1, 1])), pitch, 0.0
    return float(np.arctan2(rot[2, 1], rot[2, 2])), pitch, float(np.arctan2(rot[1, 0], rot[0, 0]))


def transform(xyz: Sequence[float], rpy: Sequence[float]) -> np.ndarray:
    """4x4 transform of a URDF-style origin: translation ``xyz`` (m) and fixed-axis ``rpy`` (rad)."""
    t = np.eye(4)
    t[:3, :3] = rpy_matrix(rpy)
    t[:3, 3] = np.asarray(xyz, dtype=np.float64)
    return t


def dh_transform(q: float, d: float, a: float, alpha: float) -> np.ndarray:
    """One standard-DH step ``frame_{i-1} <- frame_i`` = Rz(q) Tz(d) Tx(a) Rx(alpha) (m, rad)."""
    ct, st = np.cos(q), np.sin(q)
    ca, sa = np.cos(alpha), np.sin(alpha)
    return np.array(
        [
            [ct, -st * ca, st * sa, a * ct],
            [st, ct * ca, -ct * sa, a * st],
            [0.0, sa, ca, d],
            [0.0, 0.0, 0.0, 1.0],
        ]
    )


def dh_chain(
    q: Sequence[float], d: Sequence[float], a: Sequence[float], alpha: Sequence[float]
) -> list[np.ndarray]:
    """All DH frames ``base_link <- frame_i`` for i = 0..n (frame 0 is the identity, frame n is tool0)."""
    if not (len(q) == len(d) == len(a) == len(alpha)):
        lengths = (len(q), len(d), len(a), len(alpha))
        raise ValueError(f"dh_chain: q, d, a, alpha must have equal lengths, got {lengths}")
    frames = [np.eye(4)]
    for qi, di, ai, al in zip(q, d, a, alpha, strict=True):
        frames.append(frames[-1] @ dh_transform(float(qi), float(di), float(ai), float(al)))
    return frames


def dh_fk(q: Sequence[float], d: Sequence[float], a: Sequence[float], alpha: Sequence[float]) -> np.ndarray:
    """Forward kinematics ``<arm>_base_link <- <arm>_tool0`` (4x4, metres) for joint angles ``q`` (rad).

    ``d``, ``a`` (m) and ``alpha`` (rad) are the standard DH parameters, e.g. ``geometry.robot.dh_d`` etc.
    """
    return dh_chain(q, d, a, alpha)[-1]


def arm_branch(
    q: Sequence[float], d: Sequence[float], a: Sequence[float], alpha: Sequence[float]
) -> tuple[int, int, int]:
    """IK branch of a UR configuration as signs ``(shoulder, elbow, wrist)``, each +1 or -1.

    - shoulder: +1 when the wrist (DH frame 3 origin) lies in front of the base axis, i.e. on the side the upper
      arm points to at ``q2 = 0`` (-x of DH frame 1), -1 when the arm reaches over its back;
    - elbow: sign of ``sin(q3)`` (+1 = elbow up for a shoulder-forward arm);
    - wrist: sign of ``sin(q5)`` (-1 = wrist down, the "tool straight down" configurations of this project).

    Two configurations with the same branch are joined by IK solutions without a shoulder, elbow or wrist flip.
    """
    frames = dh_chain(q, d, a, alpha)
    forward = -frames[1][:3, 0]
    shoulder = 1 if float(forward[:2] @ frames[3][:2, 3]) >= 0.0 else -1
    elbow = 1 if np.sin(q[2]) >= 0.0 else -1
    wrist = 1 if np.sin(q[4]) >= 0.0 else -1
    return shoulder, elbow, wrist


def arm_base_pose(arm_spec: Any) -> np.ndarray:
    """4x4 transform ``world <- <arm>_base_link`` of one arm (``geometry.robot.arms[name]``: xyz in m, rpy in rad)."""
    return transform(arm_spec.xyz, arm_spec.rpy)


def tool_fk(geometry: Any, arm: str, q: Sequence[float]) -> np.ndarray:
    """4x4 transform ``world <- <arm>_tool0`` for joint angles ``q`` (rad) of arm ``arm`` ("left" / "right")."""
    r = geometry.robot
    return arm_base_pose(r.arms[arm]) @ dh_fk(q, r.dh_d, r.dh_a, r.dh_alpha)


def tcp_fk(geometry: Any, arm: str, q: Sequence[float]) -> np.ndarray:
    """4x4 transform ``world <- <arm>_gripper_tcp`` (fingertip centre, ``gripper.tcp_offset`` along tool0 z)."""
    t = tool_fk(geometry, arm, q)
    t[:3, 3] += t[:3, 2] * geometry.gripper.tcp_offset
    return t


def down_pose(x: float, y: float, z: float, yaw: float) -> np.ndarray:
    """4x4 pose in ``world`` of a tool pointing straight down (z = -world z) with x = (cos yaw, sin yaw, 0)."""
    t = np.eye(4)
    c, s = np.cos(yaw), np.sin(yaw)
    t[:3, 0] = (c, s, 0.0)
    t[:3, 1] = (s, -c, 0.0)
    t[:3, 2] = (0.0, 0.0, -1.0)
    t[:3, 3] = (x, y, z)
    return t
