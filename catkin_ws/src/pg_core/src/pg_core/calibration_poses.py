"""Where a hand-eye calibration puts the board on the tool, and the arm poses that show it to the camera (numpy
only: no ROS, no simulator). The simulated calibration (pg_sim.world.calibration_board, `pushgrasp calibrate --sim`)
and the hand-eye node that drives a real or simulated arm (pg_policy.ros.hand_eye_node, launch/calibrate.launch)
plan the same poses.

Frames: `world` (z up, the table top at z = 0); `<arm>_tool0` (the flange, DH frame 6; z out of the flange);
`board`: origin at the centre of the printed image, x to the right and y down in the image, z into the board (the
printed face looks along -z). Mount (`board_mount`): the printed face looks along tool0 +z, centred on the tool axis
`offset` m beyond the flange (past the fingertips of the gripper: the board is a plate held at the end of the
gripper), board x = tool0 x. The calibration poses point the tool up so that the board faces the camera above it.
4x4 transforms `a <- b`; units m, rad.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from scipy.spatial.transform import Rotation

from pg_core.geometry import Geometry
from pg_core.kinematics import arm_base_pose, dh_chain
from pg_core.ur_ik import closest, ik_all

MOUNT_OFFSET_M = 0.16  # flange -> printed face along tool0 z: 1 cm beyond the fingertips (tcp_offset 0.15)


def board_mount(offset: float = MOUNT_OFFSET_M) -> np.ndarray:
    """4x4 tool0 <- board: board z = -tool0 z (the print faces along tool0 z), x = tool0 x, at `offset` m."""
    t = np.eye(4)
    t[:3, :3] = np.diag([1.0, -1.0, -1.0])
    t[2, 3] = offset
    return t


def board_poses(n: int = 12, centre: Sequence[float] = (0.0, 0.0, 0.40), spread_xy: float = 0.05,
                spread_z: float = 0.04, max_tilt_deg: float = 25.0) -> list[np.ndarray]:
    """`n` 4x4 world <- board poses facing the camera above the table: board z = -world z tilted by up to
    `max_tilt_deg` about a horizontal axis turning with the pose index, a yaw of +-40 deg, positions on a
    deterministic spread of +-`spread_xy` m in x, y and +-`spread_z` m in z about `centre` (m)."""
    poses = []
    golden = (np.sqrt(5.0) - 1.0) / 2.0
    for i in range(n):
        f = (i + 0.5) / n
        phase = 2 * np.pi * golden * i
        xyz = np.asarray(centre, dtype=np.float64) + np.array(
            [spread_xy * np.cos(phase), spread_xy * np.sin(phase), spread_z * (2 * f - 1)])
        tilt = np.radians(max_tilt_deg) * (0.4 + 0.6 * ((i * 7) % n) / max(n - 1, 1))
        tilt_axis = np.array([np.cos(phase * 1.7), np.sin(phase * 1.7), 0.0])
        yaw = np.radians(40.0) * np.sin(2 * np.pi * golden * 3 * i)
        facing = Rotation.from_rotvec(tilt * tilt_axis) * Rotation.from_euler("z", yaw)
        t = np.eye(4)
        # the face up: board frame = world rotated by pi about x, then the tilt and the yaw
        t[:3, :3] = (facing * Rotation.from_euler("x", np.pi)).as_matrix()
        t[:3, 3] = xyz
        poses.append(t)
    return poses


def tool_targets(poses: Sequence[np.ndarray], mount: np.ndarray) -> list[np.ndarray]:
    """4x4 world <- tool0 that puts the board at each of `poses` (world <- board)."""
    inv = np.linalg.inv(mount)
    return [np.asarray(t) @ inv for t in poses]


def solve_tool(geometry: Geometry, arm: str, world_tool: np.ndarray, seed: Sequence[float],
               min_link_z: float = 0.08) -> np.ndarray | None:
    """Joint angles (rad) putting `arm`'s tool0 at `world_tool` (4x4): of the IK solutions (any branch) whose
    elbow, wrists and tool stay `min_link_z` m above the table, the one with the lowest elbow and wrists (away
    from the camera), then nearest to `seed`; None when unreachable."""
    r = geometry.robot
    base = arm_base_pose(r.arms[arm])
    lower, upper = np.array(r.joint_lower), np.array(r.joint_upper)
    best, best_cost = None, np.inf
    for q in ik_all(np.linalg.inv(base) @ world_tool, r.dh_d, r.dh_a, r.dh_alpha):
        heights = [(base @ f)[2, 3] for f in dh_chain(q, r.dh_d, r.dh_a, r.dh_alpha)[2:]]
        q = closest([q], np.asarray(seed, dtype=np.float64), lower, upper)
        if q is None or min(heights) < min_link_z:
            continue
        cost = max(heights) + 0.01 * float(np.abs(q - np.asarray(seed)).sum())
        if cost < best_cost:
            best, best_cost = q, cost
    return best


MIN_LINK_Z_M = 0.08  # elbow, wrists and tool stay this far above the table, at the poses and on the way
PATH_STEP_RAD = 0.02  # joint-space path check: the largest joint change between two checked configurations


def link_heights(geometry: Geometry, arm: str, q: Sequence[float]) -> list[float]:
    """World z (m) of the elbow, the three wrists and tool0 of `arm` at joints `q` (rad)."""
    r = geometry.robot
    base = arm_base_pose(r.arms[arm])
    return [float((base @ f)[2, 3]) for f in dh_chain(q, r.dh_d, r.dh_a, r.dh_alpha)[2:]]


def joint_path_clear(geometry: Geometry, arm: str, q_from: Sequence[float], q_to: Sequence[float],
                     min_link_z: float = MIN_LINK_Z_M, step: float = PATH_STEP_RAD) -> bool:
    """Whether the straight joint-space motion from `q_from` to `q_to` (what a joint trajectory with two points
    does) keeps the elbow, wrists and tool `min_link_z` m above the table, checked every `step` rad."""
    a, b = np.asarray(q_from, dtype=np.float64), np.asarray(q_to, dtype=np.float64)
    n = max(1, int(np.ceil(float(np.abs(b - a).max()) / step)))
    return all(min(link_heights(geometry, arm, a + (b - a) * (i / n))) >= min_link_z for i in range(n + 1))


def calibration_plan(geometry: Geometry, arm: str, start: Sequence[float], poses: int = 12,
                     mount: np.ndarray | None = None, min_link_z: float = MIN_LINK_Z_M) -> list[np.ndarray]:
    """Joint targets (rad) that show the board at up to `poses` of `board_poses`, in visiting order from `start`:
    a pose is kept when it is reachable (solve_tool) and the joint motion from the previous kept one (or `start`)
    is clear of the table (joint_path_clear). The way back to `start` from the last one is checked too: the last
    targets are dropped until it is clear."""
    mount = board_mount() if mount is None else np.asarray(mount, dtype=np.float64)
    start_q = np.asarray(start, dtype=np.float64)
    plan: list[np.ndarray] = []
    previous = start_q
    for target in tool_targets(board_poses(poses), mount):
        q = solve_tool(geometry, arm, target, previous, min_link_z)
        if q is not None and joint_path_clear(geometry, arm, previous, q, min_link_z):
            plan.append(q)
            previous = q
    while plan and not joint_path_clear(geometry, arm, plan[-1], start_q, min_link_z):
        plan.pop()
    return plan
