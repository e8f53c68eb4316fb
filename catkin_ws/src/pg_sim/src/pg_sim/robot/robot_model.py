"""Index of the shared URDF as loaded in PyBullet: joints and links of each arm and gripper, by name.

Names follow DESIGN.md section 3: `<arm>_<joint>` for the six UR joints, `<arm>_tool0`, `<arm>_gripper_tcp`,
`<arm>_gripper_finger1_joint` / `<arm>_gripper_finger2_joint` (prismatic, opening = q1 + q2 in metres).
"""

from __future__ import annotations

from dataclasses import dataclass

import pybullet as p

from pg_core.geometry import Geometry


@dataclass(frozen=True)
class ArmIndex:
    """PyBullet indices of one arm inside the robot body."""

    name: str
    joints: tuple[int, ...]  # six UR joints, base to wrist
    tool0: int
    tcp: int
    fingers: tuple[int, int]
    palm: int  # the gripper's palm link


@dataclass(frozen=True)
class RobotIndex:
    body: int
    arms: dict[str, ArmIndex]
    movable: tuple[int, ...]  # every non-fixed joint, in PyBullet order (what IK returns values for)


def load_robot(client: int, geometry: Geometry) -> RobotIndex:
    """Load the shared URDF at the world origin (fixed base) and index it, the finger pads given the configuration's
    friction (`gripper.pad_friction`, `pad_rolling_friction`: a geometry config copy reaches the simulated pads
    without a regenerated URDF); raises FileNotFoundError/KeyError."""
    urdf = geometry.robot.urdf
    if not urdf.is_file():
        raise FileNotFoundError(f"robot URDF not found: {urdf} "
                                "(generate it with `python -m pg_sim.robot.urdf_builder`)")
    body = p.loadURDF(
        str(urdf),
        useFixedBase=True,
        flags=p.URDF_USE_INERTIA_FROM_FILE | p.URDF_USE_SELF_COLLISION_EXCLUDE_PARENT,
        physicsClientId=client,
    )
    index = index_robot(client, body, geometry)
    grip = geometry.gripper
    for arm in index.arms.values():
        for finger in arm.fingers:  # a joint's child link has the joint's index
            p.changeDynamics(body, finger, lateralFriction=grip.pad_friction,
                             rollingFriction=grip.pad_rolling_friction, physicsClientId=client)
    return index


def index_robot(client: int, body: int, geometry: Geometry) -> RobotIndex:
    joints: dict[str, int] = {}
    links: dict[str, int] = {}
    movable = []
    for j in range(p.getNumJoints(body, physicsClientId=client)):
        info = p.getJointInfo(body, j, physicsClientId=client)
        joints[info[1].decode()] = j
        links[info[12].decode()] = j
        if info[2] != p.JOINT_FIXED:
            movable.append(j)

    def need(table: dict[str, int], name: str) -> int:
        if name not in table:
            raise KeyError(f"URDF {geometry.robot.urdf} has no joint/link '{name}'")
        return table[name]

    arms = {}
    for arm in geometry.robot.arms:
        arms[arm] = ArmIndex(
            name=arm,
            joints=tuple(need(joints, f"{arm}_{n}") for n in geometry.robot.joint_names),
            tool0=need(links, f"{arm}_tool0"),
            tcp=need(links, f"{arm}_gripper_tcp"),
            fingers=(need(joints, f"{arm}_gripper_finger1_joint"), need(joints, f"{arm}_gripper_finger2_joint")),
            palm=need(links, f"{arm}_gripper_palm_link"),
        )
    return RobotIndex(body=body, arms=arms, movable=tuple(movable))
