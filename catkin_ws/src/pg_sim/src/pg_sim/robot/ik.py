"""Inverse kinematics of the gripper TCP in `world` for either arm, on the closed-form UR solution.

Poses are TCP (fingertip centre) poses: position (m) in `world` and a down-pointing gripper rotated by `yaw` (rad)
about world z, i.e. tool z = -world z and tool x (the closing axis) = (cos yaw, sin yaw, 0).
"""

from __future__ import annotations

import numpy as np

from pg_core.geometry import Geometry
from pg_core.kinematics import arm_base_pose, down_pose
from pg_core.ur_ik import closest, ik_all


class IkSolver:
    """TCP inverse kinematics per arm; `solve` returns six joint angles (rad) or None when unreachable."""

    def __init__(self, geometry: Geometry) -> None:
        self.geometry_ = geometry
        r = geometry.robot
        self.base_inv_ = {name: np.linalg.inv(arm_base_pose(spec)) for name, spec in r.arms.items()}
        self.lower_ = np.array(r.joint_lower)
        self.upper_ = np.array(r.joint_upper)
        self.tcp_to_tool0_ = np.eye(4)
        self.tcp_to_tool0_[2, 3] = -geometry.gripper.tcp_offset

    def close(self) -> None:
        """Nothing to release (kept so callers can treat solvers uniformly)."""

    def tool0_target(self, arm: str, pos: np.ndarray, yaw: float) -> np.ndarray:
        """4x4 base_link <- tool0 for a down-pointing TCP at `pos` (world, m) with `yaw` (rad)."""
        tcp = down_pose(float(pos[0]), float(pos[1]), float(pos[2]), yaw)
        return self.base_inv_[arm] @ tcp @ self.tcp_to_tool0_

    def solve(self, arm: str, pos: np.ndarray, yaw: float, seed: np.ndarray) -> np.ndarray | None:
        """Joint angles (rad) reaching the TCP pose on the arm's IK branch, nearest to `seed`; None if unreachable."""
        r = self.geometry_.robot
        sols = ik_all(self.tool0_target(arm, pos, yaw), r.dh_d, r.dh_a, r.dh_alpha, branch=r.arms[arm].ik_branch)
        return closest(sols, np.asarray(seed, dtype=np.float64), self.lower_, self.upper_)
