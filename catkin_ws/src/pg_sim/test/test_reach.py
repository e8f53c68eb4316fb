"""Arm placement (DESIGN.md sections 3-4): both arms reach the whole workspace with the gripper straight down.

For every TCP pose of a grid over the workspace (corners, edges, centre; TCP heights 0.005 and 0.30 m; 8 yaws),
PyBullet IK of each arm, started from its home, must reach the pose within 2 mm / 0.02 rad, on the home's IK
branch (no shoulder, elbow or wrist flip), with no link below the table plane, no self-collision, no contact with
the other arm at home or with the camera mount. Home itself must be invisible to the camera and clear of everything.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from pg_core.kinematics import arm_branch, down_pose, tcp_fk
from pg_sim.robot.urdf_builder import ARMS

POS_TOL = 2e-3  # m
ANG_TOL = 0.02  # rad
XY = (-0.224, -0.112, 0.0, 0.112, 0.224)
HEIGHTS = (0.005, 0.30)
YAWS = tuple(k * math.pi / 4 for k in range(8))


def _grid(geometry):
    ws = geometry.workspace
    assert XY[0] == ws.x[0] and XY[-1] == ws.x[1] and XY[0] == ws.y[0] and XY[-1] == ws.y[1]
    return [(x, y, z, yaw) for z in HEIGHTS for x in XY for y in XY for yaw in YAWS]


def _quat(yaw: float) -> np.ndarray:
    return Rotation.from_matrix(down_pose(0.0, 0.0, 0.0, yaw)[:3, :3]).as_quat()


@pytest.mark.parametrize("arm", ARMS)
def test_reach_whole_workspace_pointing_down(urdf_robot, urdf_geometry, arm):
    rb, r = urdf_robot, urdf_geometry.robot
    rb.home_all()
    home_branch = arm_branch(r.arms[arm].home, r.dh_d, r.dh_a, r.dh_alpha)
    lo, hi = np.array(r.joint_lower), np.array(r.joint_upper)
    failures = []
    worst = {"pos": 0.0, "ang": 0.0, "ground": 1.0, "self": 1.0, "other": 1.0, "mount": 1.0}
    try:
        for x, y, z, yaw in _grid(urdf_geometry):
            q, pos_err, ang_err = rb.solve_ik(arm, (x, y, z), _quat(yaw))
            checks = {
                "pos": pos_err,
                "ang": ang_err,
                "ground": rb.ground_clearance(arm),
                "self": rb.self_clearance(arm),
                "other": rb.other_arm_clearance(arm),
                "mount": rb.mount_clearance(arm),
            }
            for k in ("pos", "ang"):
                worst[k] = max(worst[k], checks[k])
            for k in ("ground", "self", "other", "mount"):
                worst[k] = min(worst[k], checks[k])
            # the IK result agrees with the closed-form model of the same URDF
            fk = tcp_fk(urdf_geometry, arm, q)
            bad = [k for k in ("pos",) if checks[k] > POS_TOL] + [k for k in ("ang",) if checks[k] > ANG_TOL]
            bad += [k for k in ("ground", "self", "other", "mount") if checks[k] < 0.0]
            if np.any(q < lo - 1e-6) or np.any(q > hi + 1e-6):
                bad.append("limits")
            if arm_branch(q, r.dh_d, r.dh_a, r.dh_alpha) != home_branch:
                bad.append("branch")
            if np.linalg.norm(fk[:3, 3] - (x, y, z)) > POS_TOL:
                bad.append("dh_fk")
            if bad:
                failures.append(((x, y, z, round(yaw, 3)), bad, {k: round(v, 4) for k, v in checks.items()}))
    finally:
        rb.home_all()
    print(f"{arm}: worst {worst}")
    assert not failures, f"{len(failures)} unreachable poses, first ones: {failures[:5]}"


def test_home_is_out_of_view_and_clear(urdf_robot, urdf_geometry):
    rb, r = urdf_robot, urdf_geometry.robot
    rb.home_all()
    arm_links = {lk for arm in ARMS for lk in rb.arm_links(arm)} | {
        rb.link[f"{arm}_{n}"] for arm in ARMS for n in ("tool0", "gripper_tcp")
    }
    # not in the real image, nor in one with a 15 % wider field of view (margin for calibration errors)
    for scale in (1.0, 1.15):
        seen = set(np.unique(rb.segmentation(scale)).tolist())
        assert not (seen & arm_links), f"arm links visible at home (fov x{scale}): {seen & arm_links}"
    for arm in ARMS:
        home = np.array(r.arms[arm].home)
        assert np.all(home >= np.array(r.joint_lower)) and np.all(home <= np.array(r.joint_upper))
        tcp = tcp_fk(urdf_geometry, arm, home)
        assert tcp[2, 3] > 0.25, f"{arm} home TCP only {tcp[2, 3]:.3f} m above the table"
        assert tcp[2, 2] < -0.99, f"{arm} home gripper does not point down"
        assert rb.ground_clearance(arm, first=4) > 0.25, "wrist and gripper at home must be well above the table"
        assert rb.self_clearance(arm) > 0.0
        assert rb.mount_clearance(arm) > 0.02
        assert rb.other_arm_clearance(arm) >= 0.05  # (the helper caps distances at 5 cm)
        # the home is on the same IK branch as the workspace poses: shoulder forward, elbow up, wrist down
        assert arm_branch(home, r.dh_d, r.dh_a, r.dh_alpha) == (1, 1, -1)
