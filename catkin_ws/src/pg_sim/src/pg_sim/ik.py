"""Inverse kinematics for the gripper TCP, solved on a private kinematic copy of the robot.

PyBullet's damped-least-squares IK starts from the body's current joint state, so seeding it from an arbitrary
configuration needs a body that can be reset freely: this module keeps one in its own DIRECT client, with no objects.
Poses are TCP poses in `world`: position (m) and a down-pointing gripper rotated by `yaw` (rad) about world z.
"""

from __future__ import annotations

import numpy as np
import pybullet as p
from scipy.spatial.transform import Rotation

from pg_policy.geometry import Geometry
from pg_sim.robot_model import load_robot


def down_quaternion(yaw: float) -> np.ndarray:
    """xyzw quaternion of a tool pointing straight down (tool z = -world z) with tool x = (cos yaw, sin yaw, 0)."""
    return (Rotation.from_euler("z", yaw) * Rotation.from_euler("x", np.pi)).as_quat()


class IkSolver:
    """TCP inverse kinematics per arm; `solve` returns six joint angles (rad) or None when unreachable."""

    def __init__(self, geometry: Geometry, pos_tol: float = 1e-3, rot_tol: float = 0.01, restarts: int = 4) -> None:
        self.geometry_ = geometry
        self.client_ = p.connect(p.DIRECT)
        self.robot_ = load_robot(self.client_, geometry)
        self.pos_tol_ = pos_tol
        self.rot_tol_ = rot_tol
        self.restarts_ = restarts
        r = geometry.robot
        n = len(self.robot_.movable)
        self.lower_, self.upper_ = np.full(n, -2 * np.pi), np.full(n, 2 * np.pi)
        for arm in self.robot_.arms.values():
            for k, j in enumerate(arm.joints):
                i = self.robot_.movable.index(j)
                self.lower_[i], self.upper_[i] = r.joint_lower[k], r.joint_upper[k]
            for j in arm.fingers:
                i = self.robot_.movable.index(j)
                self.lower_[i], self.upper_[i] = 0.0, geometry.gripper.max_opening / 2
        self.rng_ = np.random.default_rng(0)

    def close(self) -> None:
        if p.isConnected(self.client_):
            p.disconnect(self.client_)

    def _reset(self, arm: str, q: np.ndarray) -> None:
        for j, v in zip(self.robot_.arms[arm].joints, q, strict=True):
            p.resetJointState(self.robot_.body, j, float(v), physicsClientId=self.client_)

    def fk(self, arm: str, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """TCP position (m) and xyzw quaternion in world at joint angles q."""
        self._reset(arm, q)
        st = p.getLinkState(self.robot_.body, self.robot_.arms[arm].tcp, computeForwardKinematics=True,
                            physicsClientId=self.client_)
        return np.array(st[4]), np.array(st[5])

    def error(self, arm: str, q: np.ndarray, pos: np.ndarray, quat: np.ndarray) -> tuple[float, float]:
        """(position error m, rotation error rad) of the TCP at q against a target pose."""
        fp, fq = self.fk(arm, q)
        rot = (Rotation.from_quat(fq).inv() * Rotation.from_quat(quat)).magnitude()
        return float(np.linalg.norm(fp - pos)), float(rot)

    def solve(self, arm: str, pos: np.ndarray, yaw: float, seed: np.ndarray) -> np.ndarray | None:
        """Joint angles reaching TCP pose (pos, down, yaw), closest to `seed` among the tries; None if unreachable."""
        quat = down_quaternion(yaw)
        pos = np.asarray(pos, dtype=np.float64)
        seed = np.asarray(seed, dtype=np.float64)
        idx = [self.robot_.movable.index(j) for j in self.robot_.arms[arm].joints]
        best: np.ndarray | None = None
        for attempt in range(self.restarts_ + 1):
            start = seed if attempt == 0 else seed + self.rng_.normal(0.0, 0.3, 6)
            q = self._iterate(arm, pos, quat, start, idx)
            if q is None:
                continue
            if best is None or np.abs(q - seed).sum() < np.abs(best - seed).sum():
                best = q
            if attempt == 0:
                break
        return best

    def _iterate(self, arm: str, pos: np.ndarray, quat: np.ndarray, start: np.ndarray, idx: list[int]):
        self._reset(arm, start)
        rest = np.zeros(len(self.robot_.movable))
        rest[idx] = start
        q = start
        for _ in range(4):
            sol = p.calculateInverseKinematics(
                self.robot_.body, self.robot_.arms[arm].tcp, pos.tolist(), quat.tolist(),
                lowerLimits=self.lower_.tolist(), upperLimits=self.upper_.tolist(),
                jointRanges=(self.upper_ - self.lower_).tolist(), restPoses=rest.tolist(),
                maxNumIterations=100, residualThreshold=1e-6, physicsClientId=self.client_,
            )
            q = np.clip(np.array(sol)[idx], np.array(self.geometry_.robot.joint_lower),
                        np.array(self.geometry_.robot.joint_upper))
            pe, re = self.error(arm, q, pos, quat)  # leaves the copy at q: the next iteration starts there
            if pe < self.pos_tol_ and re < self.rot_tol_:
                return q
        return None
