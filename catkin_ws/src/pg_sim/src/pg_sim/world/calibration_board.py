"""A printed calibration board on the tool of a simulated arm, and the arm poses that show it to the camera (ROS-free).

The board is a visual-only PyBullet body (no collision, no mass): a textured quad (the printed image) in front of
a thin white plate, placed at the tool each time `follow` is called, so what the camera renders is exactly the
board at `world <- tool0 <- board` of the arm's current joints. pg_sim knows nothing of ChArUco: the caller gives
the image and its printed size.

Frames: `world`; `<arm>_tool0` (the flange, DH frame 6; z out of the flange); `board`: origin at the centre of the
printed image, x to the right and y down in the image, z into the board (the printed face looks along -z).
Mount (`board_mount`): the printed face looks along tool0 +z, centred on the tool axis `offset` m beyond the flange
(past the fingertips of the gripper: the board is a plate held at the end of the gripper), board x = tool0 x.
The calibration poses point the tool up so that the board faces the camera above it. Units: m, rad.
"""

from __future__ import annotations

import tempfile
from collections.abc import Sequence
from pathlib import Path

import cv2
import numpy as np
import pybullet as p
from scipy.spatial.transform import Rotation

from pg_core.geometry import Geometry
from pg_sim.robot.kinematics import arm_base_pose, dh_chain
from pg_sim.robot.ur_ik import closest, ik_all

MOUNT_OFFSET_M = 0.16  # flange -> printed face along tool0 z: 1 cm beyond the fingertips (tcp_offset 0.15)
PLATE_M = 0.004        # thickness of the plate behind the print


def board_mount(offset: float = MOUNT_OFFSET_M) -> np.ndarray:
    """4x4 tool0 <- board: board z = -tool0 z (the print faces along tool0 z), x = tool0 x, at `offset` m."""
    t = np.eye(4)
    t[:3, :3] = np.diag([1.0, -1.0, -1.0])
    t[2, 3] = offset
    return t


def _quad_obj(path: Path, width: float, height: float) -> None:
    """An OBJ quad of (width, height) m in the board frame's z = 0 plane, normal -z, UVs covering the image."""
    w, h = width / 2, height / 2
    path.write_text(
        "# calibration board print: board frame, the face looks along -z\n"
        f"v {-w} {-h} 0\nv {w} {-h} 0\nv {w} {h} 0\nv {-w} {h} 0\n"
        "vt 0 1\nvt 1 1\nvt 1 0\nvt 0 0\n"
        "vn 0 0 -1\n"
        "f 1/1/1 3/3/1 2/2/1\nf 1/1/1 4/4/1 3/3/1\n"
    )


class SimBoard:
    """The board of printed `image` ((H, W) or (H, W, 3) uint8; its first row at board y = -height/2) and
    `size_m` (width, height) m, mounted by `mount` (4x4 tool0 <- board) on `arm`. Call `follow` after every arm
    motion and before rendering; `remove` (or the world's disconnect) deletes it."""

    def __init__(self, client: int, geometry: Geometry, body: int, tool_link: int, arm: str, image: np.ndarray,
                 size_m: tuple[float, float], mount: np.ndarray | None = None) -> None:
        self.client_ = client
        self.geometry_ = geometry
        self.robot_body_ = body
        self.tool_link_ = tool_link
        self.arm = arm
        self.size_m = (float(size_m[0]), float(size_m[1]))
        self.mount = board_mount() if mount is None else np.asarray(mount, dtype=np.float64)
        self.dir_ = tempfile.TemporaryDirectory(prefix="pg_board_")
        folder = Path(self.dir_.name)
        rgb = image if image.ndim == 3 else cv2.cvtColor(image, cv2.COLOR_GRAY2RGB)
        cv2.imwrite(str(folder / "board.png"), cv2.cvtColor(rgb, cv2.COLOR_RGB2BGR))
        _quad_obj(folder / "board.obj", *self.size_m)
        face = p.createVisualShape(p.GEOM_MESH, fileName=str(folder / "board.obj"), rgbaColor=[1, 1, 1, 1],
                                   physicsClientId=client)
        plate = p.createVisualShape(p.GEOM_BOX, halfExtents=[self.size_m[0] / 2, self.size_m[1] / 2, PLATE_M / 2],
                                    rgbaColor=[0.9, 0.9, 0.9, 1], physicsClientId=client)
        # the print 0.2 mm in front of the plate (towards -z) so the renderer never mixes the two
        self.body = p.createMultiBody(baseMass=0.0, baseCollisionShapeIndex=-1, baseVisualShapeIndex=face,
                                      linkMasses=[0.0], linkCollisionShapeIndices=[-1],
                                      linkVisualShapeIndices=[plate], linkPositions=[[0, 0, PLATE_M / 2 + 2e-4]],
                                      linkOrientations=[[0, 0, 0, 1]], linkInertialFramePositions=[[0, 0, 0]],
                                      linkInertialFrameOrientations=[[0, 0, 0, 1]], linkParentIndices=[0],
                                      linkJointTypes=[p.JOINT_FIXED], linkJointAxis=[[0, 0, 1]],
                                      physicsClientId=client)
        texture = p.loadTexture(str(folder / "board.png"), physicsClientId=client)
        p.changeVisualShape(self.body, -1, textureUniqueId=texture, physicsClientId=client)
        self.follow()

    def tool_pose(self) -> np.ndarray:
        """4x4 world <- tool0 of the arm as PyBullet has it now."""
        state = p.getLinkState(self.robot_body_, self.tool_link_, computeForwardKinematics=True,
                               physicsClientId=self.client_)
        t = np.eye(4)
        t[:3, :3] = Rotation.from_quat(state[5]).as_matrix()
        t[:3, 3] = state[4]
        return t

    def pose(self) -> np.ndarray:
        """4x4 world <- board now: the tool pose times the mount."""
        return self.tool_pose() @ self.mount

    def follow(self) -> np.ndarray:
        """Place the board at the tool; returns its pose (4x4 world <- board)."""
        t = self.pose()
        p.resetBasePositionAndOrientation(self.body, t[:3, 3].tolist(),
                                          Rotation.from_matrix(t[:3, :3]).as_quat().tolist(),
                                          physicsClientId=self.client_)
        return t

    def remove(self) -> None:
        if p.isConnected(self.client_):
            p.removeBody(self.body, physicsClientId=self.client_)
        self.dir_.cleanup()


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
