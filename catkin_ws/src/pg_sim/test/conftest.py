"""Shared fixtures of the URDF / reach tests: the geometry config and the robot URDF loaded in PyBullet DIRECT.

Fixture names carry a `urdf_` prefix so they do not collide with fixtures of the other pg_sim tests.
"""

from __future__ import annotations

import math

import numpy as np
import pybullet as p
import pytest
from scipy.spatial.transform import Rotation

from pg_core.geometry import Geometry, load
from pg_sim.robot.urdf_builder import ARM_LINKS, ARMS


class BulletRobot:
    """The committed URDF in its own PyBullet DIRECT client, indexed by link and joint name."""

    def __init__(self, geometry: Geometry) -> None:
        self.geometry = geometry
        self.cid = p.connect(p.DIRECT)
        self.body = p.loadURDF(
            str(geometry.robot.urdf), useFixedBase=True, flags=p.URDF_USE_INERTIA_FROM_FILE, physicsClientId=self.cid
        )
        # a ground slab whose top face is z = 0 over a large area (the table only covers 1.2 x 1.6 m)
        self.ground = p.createMultiBody(
            0,
            p.createCollisionShape(p.GEOM_BOX, halfExtents=[5, 5, 0.5], physicsClientId=self.cid),
            basePosition=[0, 0, -0.5],
            physicsClientId=self.cid,
        )
        self.link: dict[str, int] = {}
        self.joint: dict[str, int] = {}
        self.parent: dict[int, int] = {}
        self.fixed: dict[int, bool] = {}
        self.movable: list[int] = []
        for j in range(p.getNumJoints(self.body, physicsClientId=self.cid)):
            info = p.getJointInfo(self.body, j, physicsClientId=self.cid)
            self.joint[info[1].decode()] = j
            self.link[info[12].decode()] = j
            self.parent[j] = info[16]
            self.fixed[j] = info[2] == p.JOINT_FIXED
            if info[2] != p.JOINT_FIXED:
                self.movable.append(j)
        self.lower = [p.getJointInfo(self.body, j, physicsClientId=self.cid)[8] for j in self.movable]
        self.upper = [p.getJointInfo(self.body, j, physicsClientId=self.cid)[9] for j in self.movable]
        self.arm_joints = {a: [self.joint[f"{a}_{n}"] for n in geometry.robot.joint_names] for a in ARMS}
        self.home_all()

    def close(self) -> None:
        p.disconnect(self.cid)

    # -- state ----------------------------------------------------------------------------------------------------
    def set_arm(self, arm: str, q) -> None:
        for j, v in zip(self.arm_joints[arm], q, strict=True):
            p.resetJointState(self.body, j, float(v), physicsClientId=self.cid)

    def arm_q(self, arm: str) -> np.ndarray:
        return np.array([p.getJointState(self.body, j, physicsClientId=self.cid)[0] for j in self.arm_joints[arm]])

    def home_all(self) -> None:
        for arm in ARMS:
            self.set_arm(arm, self.geometry.robot.arms[arm].home)
        for j in self.movable:
            if j not in self.arm_joints["left"] + self.arm_joints["right"]:
                p.resetJointState(self.body, j, 0.0, physicsClientId=self.cid)

    def frame(self, link: str) -> np.ndarray:
        """4x4 world <- URDF link frame (not the COM frame)."""
        s = p.getLinkState(self.body, self.link[link], computeForwardKinematics=True, physicsClientId=self.cid)
        t = np.eye(4)
        t[:3, :3] = np.array(p.getMatrixFromQuaternion(s[5])).reshape(3, 3)
        t[:3, 3] = s[4]
        return t

    # -- links and contacts -----------------------------------------------------------------------------------------
    def arm_links(self, arm: str) -> list[int]:
        """Every link with collision geometry that moves with (or carries) the arm."""
        names = ["base_link", *ARM_LINKS, "gripper_palm_link", "gripper_finger1_link", "gripper_finger2_link"]
        return [self.link[f"{arm}_{n}"] for n in names]

    def _rigid_root(self, link: int) -> int:
        """The first link up the tree that moves relative to its parent (-1: rigidly attached to the world)."""
        while link >= 0 and self.fixed[link]:
            link = self.parent[link]
        return link

    def self_collision_pairs(self, arm: str) -> list[tuple[int, int]]:
        """Link pairs of one arm that must never touch: not rigidly joined, not parent/child across one joint,
        and not the two fingers (they touch by design when the gripper is closed)."""
        links = self.arm_links(arm)
        fingers = {self.link[f"{arm}_gripper_finger1_link"], self.link[f"{arm}_gripper_finger2_link"]}
        pairs = []
        for i, a in enumerate(links):
            for b in links[i + 1 :]:
                ra, rb = self._rigid_root(a), self._rigid_root(b)
                if ra == rb or {a, b} == fingers:
                    continue
                parent_a = self._rigid_root(self.parent[ra]) if ra >= 0 else None
                parent_b = self._rigid_root(self.parent[rb]) if rb >= 0 else None
                if parent_a == rb or parent_b == ra:
                    continue
                pairs.append((a, b))
        return pairs

    def min_distance(self, pairs, body_b: int | None = None, reach: float = 0.05) -> float:
        """Smallest signed distance (m, < 0 = penetration) over link pairs, capped at `reach`."""
        best = reach
        for a, b in pairs:
            kw = {"linkIndexA": a}
            if b is not None:
                kw["linkIndexB"] = b
            for c in p.getClosestPoints(
                self.body, self.body if body_b is None else body_b, reach, physicsClientId=self.cid, **kw
            ):
                best = min(best, c[8])
        return best

    def ground_clearance(self, arm: str, first: int = 1) -> float:
        """Distance above the z = 0 plane of the arm's links from `first` on (0 base_link, 1 shoulder, ..., 6 wrist 3,
        7 palm, 8-9 fingers; the default skips the base sitting on the table)."""
        return self.min_distance([(lk, None) for lk in self.arm_links(arm)[first:]], body_b=self.ground, reach=1.0)

    def self_clearance(self, arm: str) -> float:
        return self.min_distance(self.self_collision_pairs(arm))

    def other_arm_clearance(self, arm: str) -> float:
        other = [o for o in ARMS if o != arm][0]
        return self.min_distance([(a, b) for a in self.arm_links(arm) for b in self.arm_links(other)])

    def mount_clearance(self, arm: str) -> float:
        mount = [self.link["camera_mount_link"], self.link["camera_link"]]
        return self.min_distance([(a, b) for a in self.arm_links(arm) for b in mount])

    # -- inverse kinematics ---------------------------------------------------------------------------------------
    def solve_ik(self, arm: str, pos, quat, rounds: int = 5, iterations: int = 100) -> tuple[np.ndarray, float, float]:
        """PyBullet IK of `<arm>_gripper_tcp` from the arm's home: the first call with restPoses = home, then
        re-seeded from the previous result. Returns (q, position error m, orientation error rad)."""
        home = self.geometry.robot.arms[arm].home
        self.set_arm(arm, home)
        rest = [p.getJointState(self.body, j, physicsClientId=self.cid)[0] for j in self.movable]
        ranges = [u - lo for lo, u in zip(self.lower, self.upper, strict=True)]
        tcp = self.link[f"{arm}_gripper_tcp"]
        q, pos_err, ang_err = np.array(home), math.inf, math.inf
        for _ in range(rounds):
            sol = p.calculateInverseKinematics(
                self.body,
                tcp,
                list(pos),
                list(quat),
                lowerLimits=self.lower,
                upperLimits=self.upper,
                jointRanges=ranges,
                restPoses=rest,
                maxNumIterations=iterations,
                residualThreshold=1e-5,
                physicsClientId=self.cid,
            )
            q = np.array([sol[self.movable.index(j)] for j in self.arm_joints[arm]])
            self.set_arm(arm, q)
            t = self.frame(f"{arm}_gripper_tcp")
            pos_err = float(np.linalg.norm(t[:3, 3] - np.asarray(pos)))
            target = Rotation.from_quat(quat)
            ang_err = float((Rotation.from_matrix(t[:3, :3]) * target.inv()).magnitude())
            if pos_err < 1e-4 and ang_err < 1e-3:
                break
            rest = [p.getJointState(self.body, j, physicsClientId=self.cid)[0] for j in self.movable]
        return q, pos_err, ang_err

    # -- camera ----------------------------------------------------------------------------------------------------
    def camera_view_projection(self, fov_scale: float = 1.0):
        """PyBullet view and projection matrices of the config camera (optical frame pose, fx, fy, size, near, far);
        `fov_scale` > 1 widens the field of view (for a margin around the real frustum)."""
        cam = self.geometry.camera
        t = cam.pose
        eye, forward, up = t[:3, 3], t[:3, 2], -t[:3, 1]
        view = p.computeViewMatrix(eye.tolist(), (eye + forward).tolist(), up.tolist())
        fov = 2.0 * math.degrees(math.atan(fov_scale * cam.height / (2.0 * cam.fy)))
        proj = p.computeProjectionMatrixFOV(fov, cam.width / cam.height, cam.near, cam.far)
        return view, proj

    def segmentation(self, fov_scale: float = 1.0) -> np.ndarray:
        """Robot link index seen at each pixel of the config camera (-2: background or another body).
        The helper ground slab is moved out of sight while rendering."""
        cam = self.geometry.camera
        view, proj = self.camera_view_projection(fov_scale)
        p.resetBasePositionAndOrientation(self.ground, [0, 0, -100], [0, 0, 0, 1], physicsClientId=self.cid)
        img = p.getCameraImage(
            cam.width,
            cam.height,
            view,
            proj,
            renderer=p.ER_TINY_RENDERER,
            flags=p.ER_SEGMENTATION_MASK_OBJECT_AND_LINKINDEX,
            physicsClientId=self.cid,
        )
        p.resetBasePositionAndOrientation(self.ground, [0, 0, -0.5], [0, 0, 0, 1], physicsClientId=self.cid)
        seg = np.asarray(img[4]).reshape(img[1], img[0])
        obj = np.where(seg >= 0, seg & ((1 << 24) - 1), -1)
        link = np.where(seg >= 0, (seg >> 24) - 1, -1)
        return np.where(obj == self.body, link, -2)


@pytest.fixture(scope="session")
def urdf_geometry() -> Geometry:
    return load()


@pytest.fixture(scope="module")
def urdf_robot(urdf_geometry):
    robot = BulletRobot(urdf_geometry)
    yield robot
    robot.close()
