"""The camera's hand-eye calibration run in a simulated world, as `pushgrasp calibrate --sim` and the evaluation's
`--calibrate` do it (no ROS).

The ChArUco board (pg_sim.world.calibration_board) on an arm's tool visits `poses` poses above the workspace
(kinematically: the world must hold no objects), the camera captures each, and pg_policy.perception.hand_eye solves
the camera pose in `world` and the depth scale and offset against the table. The arm goes home and the board is
removed afterwards. Poses: 4x4 world <- optical frame, metres. Raised: hand_eye.CalibrationFailed when too few
views see the board or the solution does not hold.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from pg_sim.world.world import World


@dataclass(frozen=True)
class SimCalibration:
    """A simulated calibration: the solution, the depth fit, the true camera pose and the configured one."""

    result: object          # pg_policy.perception.hand_eye.HandEyeResult
    depth: object           # pg_policy.perception.hand_eye.DepthFit
    true_pose: np.ndarray   # 4x4 world <- optical frame the camera renders from
    configured: np.ndarray  # 4x4 world <- optical frame of the geometry config

    @property
    def errors(self) -> tuple[float, float]:
        """(position error mm, rotation error deg) of the solution against the true pose."""
        from pg_policy.perception.hand_eye import angle_deg

        x = self.result.world_camera  # type: ignore[attr-defined]
        return 1e3 * float(np.linalg.norm(x[:3, 3] - self.true_pose[:3, 3])), angle_deg(x, self.true_pose)


def calibrate_camera(world: World, poses: int = 12, arm: str = "left") -> SimCalibration:
    """Calibrate `world`'s camera (module docstring); the world's camera is left as it was."""
    from pg_core.calibration_poses import board_poses, solve_tool, tool_targets
    from pg_core.kinematics import tool_fk
    from pg_policy.perception.charuco import DEFAULT_BOARD, detect
    from pg_policy.perception.hand_eye import View, depth_pairs, fit_depth, solve

    spec = DEFAULT_BOARD
    cam, driver = world.camera, world.arms[arm]
    home = np.asarray(world.geometry.robot.arms[arm].home, dtype=np.float64)
    table_depth = cam.capture().depth  # both arms at home: the camera sees the table alone
    board = world.attach_board(arm, spec)
    try:
        seed_q, views = home, []
        for target in tool_targets(board_poses(poses), board.mount):
            q = solve_tool(world.geometry, arm, target, seed_q)
            if q is None:
                continue
            driver.reset(q, world.geometry.gripper.max_opening)  # kinematic: the table is empty
            seed_q = q
            board.follow()
            # the tool pose as a robot reports it: forward kinematics of the joint readings
            frame = cam.capture()
            views.append(View(tool_fk(world.geometry, arm, driver.joints()), detect(spec, frame.color), frame.depth))
        result = solve(views, spec, cam.intrinsics)
        depth_fit = fit_depth(depth_pairs(result, views, table_depth, cam.intrinsics, spec))
    finally:
        world.detach_board()
        driver.reset(home, world.geometry.gripper.max_opening)
    return SimCalibration(result, depth_fit, cam.render_pose.copy(), cam.pose.copy())
