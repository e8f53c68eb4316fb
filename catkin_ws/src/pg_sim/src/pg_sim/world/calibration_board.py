"""A printed calibration board on the tool of a simulated arm (ROS-free).

The board is a visual-only PyBullet body (no collision, no mass): a textured quad (the printed image) in front of
a thin white plate, placed at the tool each time `follow` is called, so what the camera renders is exactly the
board at `world <- tool0 <- board` of the arm's current joints. pg_sim knows nothing of ChArUco: the caller gives
the image and its printed size.

Frames, the mount and the poses that show the board to the camera: pg_core.calibration_poses. Units: m, rad.
"""

from __future__ import annotations

import tempfile
from pathlib import Path

import cv2
import numpy as np
import pybullet as p
from scipy.spatial.transform import Rotation

from pg_core.calibration_poses import board_mount
from pg_core.geometry import Geometry

PLATE_M = 0.004        # thickness of the plate behind the print


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
