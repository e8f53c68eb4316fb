"""Generate the one robot URDF (both UR5e arms, grippers, table, camera mount) from the geometry config.

Usage::

    python -m pg_sim.robot.urdf_builder --out catkin_ws/src/pg_description/urdf/pushgrasp.urdf   # (re)write
    python -m pg_sim.robot.urdf_builder --check        # exit 1 if the committed file differs from the config

The output is plain URDF (no xacro, no meshes) loaded alike by PyBullet, robot_state_publisher and KDL.
Units: metres, radians, kilograms. Frames (DESIGN.md section 3):

- ``world`` (root, no inertia): on the table surface at the workspace centre, x forward, y left, z up.
- ``table``: a box of ``table.size`` whose top face is z = 0, centred at ``table.center_xy``.
- ``<arm>_base_link`` (arm in left, right) at ``robot.arms.<arm>.xyz/rpy``; it IS DH frame 0.
  Every arm link frame is a DH frame: joint 1 has the identity origin and joint i+1 the origin
  ``xyz="a_i 0 d_i" rpy="alpha_i 0 0"`` in link i, all axes z, so ``<arm>_tool0`` is DH frame 6 and the URDF zero
  configuration is the DH zero configuration (``pg_core.kinematics.dh_fk`` is exact for this file).
- Gripper (2F-85-like) on tool0: ``<arm>_gripper_palm_link`` (frame = tool0), two independent prismatic fingers
  ``<arm>_gripper_finger1_joint`` (+x of tool0) and ``<arm>_gripper_finger2_joint`` (-x), each in
  [0, max_opening / 2], opening = q1 + q2 (0 = closed, inner faces touching at x = 0). No ``<mimic>``: the sim
  drives and publishes both fingers. ``<arm>_gripper_tcp`` is the fingertip centre at tool0 z = tcp_offset. The
  finger links carry ``gripper.pad_friction`` as a ``<contact>`` lateral friction (rubber pads).
- ``camera_color_optical_frame`` exactly at ``camera.xyz/rpy`` (z along the view, x right, y down in the image);
  ``camera_link`` has the same origin, rotated to REP-103 x-forward (x = optical z, y = -optical x,
  z = -optical y), i.e. ``camera_link -> camera_color_optical_frame`` is rpy (-pi/2, 0, -pi/2).
  The camera body sits behind the lens and the mount (post behind the table's -x edge, beam above the camera)
  stays outside the view frustum.

Frame-only links (tool0, tcp, camera frames) carry a negligible inertial (1 g) because PyBullet gives a link without
``<inertial>`` a mass of 1 kg and a unit inertia, which would distort the wrist dynamics.
"""

from __future__ import annotations

import argparse
import math
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from pg_core import geometry as geometry_mod
from pg_core.kinematics import matrix_rpy, transform
from pg_sim.robot.link_shapes import Shape, box, composite_inertia, principal_axes, segment

ARMS = ("left", "right")
ARM_LINKS = (
    "shoulder_link",
    "upper_arm_link",
    "forearm_link",
    "wrist_1_link",
    "wrist_2_link",
    "wrist_3_link",
)

# UR5e-like collision dimensions (m). The DH model folds the real lateral offsets of the upper arm
# (SHOULDER_OFFSET along the shoulder axis) and forearm (back by ELBOW_OFFSET) into d4; the tubes are drawn at
# those real offsets so the elbow can fold as far as on the real robot.
BASE_RADIUS = 0.075
BASE_HEIGHT = 0.07
SHOULDER_RADIUS = 0.06
UPPER_ARM_RADIUS = 0.054
ELBOW_RADIUS = 0.05
FOREARM_RADIUS = 0.045
WRIST_RADIUS = 0.045
WRIST_3_RADIUS = 0.04
SHOULDER_OFFSET = 0.138
ELBOW_OFFSET = 0.131
BASE_MASS = 4.0

# Camera mount (m, kg): an aluminium post behind the table edge, a beam above the camera, a short drop to it.
MOUNT_SECTION = 0.04
MOUNT_CLEARANCE_X = 0.08  # post distance behind the table's -x edge
MOUNT_FLOOR_Z = -0.75  # the post stands on the floor (table height 0.75)
MOUNT_BEAM_GAP = 0.05  # beam centre above the camera body top
MOUNT_MASS = 3.0
CAMERA_BODY = (0.025, 0.09, 0.025)  # camera_link x (depth, behind the lens), y (long side), z
CAMERA_MASS = 0.072
TABLE_MASS = 30.0
FRAME_MASS = 0.001  # frame-only links
FRAME_INERTIA = 1e-7

MATERIALS = {
    "ur_grey": (0.75, 0.75, 0.78, 1.0),
    "ur_blue": (0.33, 0.55, 0.80, 1.0),
    "gripper_dark": (0.15, 0.15, 0.17, 1.0),
    "gripper_pad": (0.30, 0.30, 0.32, 1.0),
    "table_wood": (0.78, 0.70, 0.58, 1.0),
    "mount_alu": (0.55, 0.57, 0.60, 1.0),
    "camera_black": (0.08, 0.08, 0.09, 1.0),
}


def _f(v: float) -> str:
    """A number as written into the URDF: 12 significant digits, round-off below 1e-12 written as 0."""
    v = float(v)
    if abs(v) < 1e-12:
        return "0"
    return f"{v:.12g}"


def _v(vals: Sequence[float]) -> str:
    return " ".join(_f(v) for v in vals)


def _origin(xyz: Sequence[float], rpy: Sequence[float]) -> str:
    return f'<origin xyz="{_v(xyz)}" rpy="{_v(rpy)}"/>'


def _geometry(s: Shape) -> str:
    if s.kind == "cylinder":
        return f'<geometry><cylinder radius="{_f(s.size[0])}" length="{_f(s.size[1])}"/></geometry>'
    return f'<geometry><box size="{_v(s.size)}"/></geometry>'


def _inertial_xml(com: Sequence[float], rpy: Sequence[float], mass: float, moments: Sequence[float]) -> list[str]:
    ixx, iyy, izz = moments
    return [
        "    <inertial>",
        f"      {_origin(com, rpy)}",
        f'      <mass value="{_f(mass)}"/>',
        f'      <inertia ixx="{_f(ixx)}" ixy="0" ixz="0" iyy="{_f(iyy)}" iyz="0" izz="{_f(izz)}"/>',
        "    </inertial>",
    ]


def _link(name: str, shapes: Sequence[Shape] = (), mass: float | None = None,
          friction: float | None = None, rolling_friction: float = 0.0) -> list[str]:
    """A link with visual+collision per shape; ``mass`` None -> a frame-only link with a negligible inertial;
    ``friction``: a ``<contact>`` lateral friction coefficient (PyBullet's URDF extension; others ignore it), None
    for none (PyBullet's default, 0.5), with ``rolling_friction`` (m) when it is above 0."""
    out = [f'  <link name="{name}">']
    if mass is None:
        out += _inertial_xml((0, 0, 0), (0, 0, 0), FRAME_MASS, (FRAME_INERTIA,) * 3)
    elif mass > 0.0:
        com, inertia = composite_inertia(shapes, mass)
        moments, rpy = principal_axes(inertia)
        out += _inertial_xml(com, rpy, mass, moments)
    for s in shapes:
        out += [
            "    <visual>",
            f"      {_origin(s.xyz, s.rpy)}",
            f"      {_geometry(s)}",
            f'      <material name="{s.material}"/>',
            "    </visual>",
        ]
    for s in shapes:
        out += [
            "    <collision>",
            f"      {_origin(s.xyz, s.rpy)}",
            f"      {_geometry(s)}",
            "    </collision>",
        ]
    if friction is not None:
        rolling = [f'      <rolling_friction value="{_f(rolling_friction)}"/>'] if rolling_friction > 0 else []
        out += ["    <contact>", f'      <lateral_friction value="{_f(friction)}"/>', *rolling, "    </contact>"]
    out.append("  </link>")
    return out


def _joint(
    name: str,
    kind: str,
    parent: str,
    child: str,
    xyz: Sequence[float] = (0, 0, 0),
    rpy: Sequence[float] = (0, 0, 0),
    axis: Sequence[float] | None = None,
    limit: tuple[float, float, float, float] | None = None,
) -> list[str]:
    out = [
        f'  <joint name="{name}" type="{kind}">',
        f'    <parent link="{parent}"/>',
        f'    <child link="{child}"/>',
        f"    {_origin(xyz, rpy)}",
    ]
    if axis is not None:
        out.append(f'    <axis xyz="{_v(axis)}"/>')
    if limit is not None:
        lo, hi, effort, vel = limit
        out.append(f'    <limit lower="{_f(lo)}" upper="{_f(hi)}" effort="{_f(effort)}" velocity="{_f(vel)}"/>')
    out.append("  </joint>")
    return out


# ------------------------------------------------------------------------------------------------------ geometry
def arm_link_shapes(robot: Any) -> dict[str, list[Shape]]:
    """Collision/visual shapes of each arm link (unprefixed names), in that link's (DH) frame.

    Link i's frame is DH frame i-1 turned by q_i about z; its next joint sits at (a_i, 0, d_i) with axis
    (0, -sin alpha_i, cos alpha_i). Every segment lies between a joint origin and the next joint origin.
    """
    d, a = robot.dh_d, robot.dh_a
    n = [np.array([0.0, -math.sin(al), math.cos(al)]) for al in robot.dh_alpha]
    z = np.array([0.0, 0.0, 1.0])
    p = [np.array([a[i], 0.0, d[i]]) for i in range(6)]
    fo = SHOULDER_OFFSET - ELBOW_OFFSET  # forearm tube offset along the elbow axis
    return {
        "base_link": [segment((0, 0, 0), (0, 0, BASE_HEIGHT), BASE_RADIUS, "ur_blue")],
        "shoulder_link": [
            segment((0, 0, BASE_HEIGHT + 0.002), p[0], SHOULDER_RADIUS, "ur_grey"),
            segment(p[0] - 0.065 * n[0], p[0] + 0.07 * n[0], SHOULDER_RADIUS, "ur_blue"),
        ],
        "upper_arm_link": [
            segment(0.075 * z, 0.20 * z, SHOULDER_RADIUS, "ur_blue"),
            segment(SHOULDER_OFFSET * z, p[1] + SHOULDER_OFFSET * z, UPPER_ARM_RADIUS, "ur_grey"),
            segment(p[1] + 0.08 * z, p[1] + 0.195 * z, ELBOW_RADIUS, "ur_blue"),
        ],
        "forearm_link": [
            segment(-0.055 * z, 0.07 * z, ELBOW_RADIUS, "ur_blue"),
            segment(fo * z, p[2] + fo * z, FOREARM_RADIUS, "ur_grey"),
            segment(p[2] - 0.05 * z, p[2] + 0.06 * z, WRIST_RADIUS, "ur_blue"),
        ],
        "wrist_1_link": [
            segment(0.065 * z, p[3] + WRIST_RADIUS * z, WRIST_RADIUS, "ur_grey"),
        ],
        "wrist_2_link": [
            segment((WRIST_RADIUS + 0.002) * z, p[4] + WRIST_RADIUS * z, WRIST_RADIUS, "ur_blue"),
        ],
        "wrist_3_link": [
            segment((WRIST_RADIUS + 0.002) * z, p[5] - 0.002 * z, WRIST_3_RADIUS, "ur_grey"),
        ],
    }


def gripper_shapes(gripper: Any) -> dict[str, list[Shape]]:
    """Shapes of the palm (tool0 frame) and of each finger (its own frame, at q = 0 equal to tool0)."""
    px, py, pz = gripper.palm_size
    ft, fw, fl = gripper.finger_size
    span = gripper.tcp_offset - pz
    if abs(span - fl) > 1e-9:
        raise ValueError(
            f"gripper: finger_size[2] ({fl}) must equal tcp_offset - palm_size[2] ({span}): fingers span palm -> tcp"
        )
    if px / 2.0 < gripper.max_opening / 2.0 + ft:
        raise ValueError("gripper: palm_size[0] must cover the fully open fingers (max_opening + 2 finger_size[0])")
    zc = pz + 0.5 * fl
    return {
        "palm": [box((px, py, pz), (0.0, 0.0, 0.5 * pz), "gripper_dark")],
        "finger1": [box((ft, fw, fl), (0.5 * ft, 0.0, zc), "gripper_pad")],
        "finger2": [box((ft, fw, fl), (-0.5 * ft, 0.0, zc), "gripper_pad")],
    }


def camera_link_pose(camera: Any) -> np.ndarray:
    """4x4 ``world <- camera_link`` (same origin as the optical frame, REP-103 x-forward)."""
    return transform(camera.xyz, camera.rpy) @ np.linalg.inv(transform((0, 0, 0), OPTICAL_IN_CAMERA_LINK_RPY))


OPTICAL_IN_CAMERA_LINK_RPY = (-math.pi / 2.0, 0.0, -math.pi / 2.0)


def mount_shapes(geometry: Any) -> list[Shape]:
    """Camera mount in the ``camera_mount_link`` frame (= world): post behind the table, beam over to the camera."""
    cam, table = geometry.camera, geometry.table
    cx, cy, cz = cam.xyz
    post_x = table.center_xy[0] - 0.5 * table.size[0] - MOUNT_CLEARANCE_X
    body_top = cz + CAMERA_BODY[0] + 0.002  # camera looks down: its body lies above the lens
    beam_z = body_top + MOUNT_BEAM_GAP
    s = MOUNT_SECTION
    top = beam_z + 0.5 * s
    return [
        box((s, s, top - MOUNT_FLOOR_Z), (post_x, cy, 0.5 * (top + MOUNT_FLOOR_Z)), "mount_alu"),
        box((cx - post_x + s, s, s), (0.5 * (cx + post_x), cy, beam_z), "mount_alu"),
        box((0.6 * s, 0.6 * s, beam_z - body_top), (cx, cy, 0.5 * (beam_z + body_top)), "mount_alu"),
    ]


# ----------------------------------------------------------------------------------------------------------- build
def build_urdf(geometry: Any) -> str:
    """The complete URDF text for ``geometry`` (a :class:`pg_core.geometry.Geometry`)."""
    robot, grip, table, cam = geometry.robot, geometry.gripper, geometry.table, geometry.camera
    missing = [a for a in ARMS if a not in robot.arms]
    if missing:
        raise ValueError(f"robot.arms must define {ARMS}, missing {missing}")
    out = [
        '<?xml version="1.0"?>',
        "<!-- GENERATED by `python -m pg_sim.robot.urdf_builder` from pg_description's workspace.yaml: do not edit "
        "by hand.",
        "     Plain URDF: two UR5e arms (link frames = standard DH frames), 2F-85-like grippers, table, camera",
        "     mount. -->",
        '<robot name="pushgrasp">',
    ]
    for name, rgba in MATERIALS.items():
        out.append(f'  <material name="{name}"><color rgba="{_v(rgba)}"/></material>')

    out.append('  <link name="world"/>')

    # table: top face at z = 0
    tx, ty, tz = table.size
    out += _link("table", [box(table.size, (0.0, 0.0, -0.5 * tz), "table_wood")], TABLE_MASS)
    out += _joint("table_joint", "fixed", "world", "table", (table.center_xy[0], table.center_xy[1], 0.0))

    # camera mount and camera frames
    out += _link("camera_mount_link", mount_shapes(geometry), MOUNT_MASS)
    out += _joint("camera_mount_joint", "fixed", "world", "camera_mount_link")
    body = box(CAMERA_BODY, (-0.5 * CAMERA_BODY[0] - 0.001, 0.0, 0.0), "camera_black")
    out += _link("camera_link", [body], CAMERA_MASS)
    t_cam = camera_link_pose(cam)
    out += _joint(
        "camera_joint", "fixed", "camera_mount_link", "camera_link", t_cam[:3, 3], matrix_rpy(t_cam[:3, :3])
    )
    out += _link("camera_color_optical_frame")
    out += _joint(
        "camera_color_optical_joint",
        "fixed",
        "camera_link",
        "camera_color_optical_frame",
        rpy=OPTICAL_IN_CAMERA_LINK_RPY,
    )

    shapes = arm_link_shapes(robot)
    gshapes = gripper_shapes(grip)
    d, a, alpha = robot.dh_d, robot.dh_a, robot.dh_alpha
    for arm in ARMS:
        spec = robot.arms[arm]
        pre = f"{arm}_"
        out.append(f"  <!-- ================= {arm} arm ================= -->")
        out += _link(pre + "base_link", shapes["base_link"], BASE_MASS)
        out += _joint(pre + "base_joint", "fixed", "world", pre + "base_link", spec.xyz, spec.rpy)
        parent = pre + "base_link"
        for i, link in enumerate(ARM_LINKS):
            out += _link(pre + link, shapes[link], robot.link_masses[i])
            xyz, rpy = ((0, 0, 0), (0, 0, 0)) if i == 0 else ((a[i - 1], 0, d[i - 1]), (alpha[i - 1], 0, 0))
            lim = (robot.joint_lower[i], robot.joint_upper[i], robot.joint_effort_limit[i], robot.joint_velocity_limit)
            out += _joint(pre + robot.joint_names[i], "revolute", parent, pre + link, xyz, rpy, (0, 0, 1), lim)
            parent = pre + link
        out += _link(pre + "tool0")
        out += _joint(pre + "tool0_joint", "fixed", parent, pre + "tool0", (a[5], 0, d[5]), (alpha[5], 0, 0))

        g = pre + "gripper_"
        out += _link(g + "palm_link", gshapes["palm"], grip.palm_mass)
        out += _joint(g + "palm_joint", "fixed", pre + "tool0", g + "palm_link")
        half = 0.5 * grip.max_opening
        flim = (0.0, half, grip.finger_force, grip.finger_speed)
        for k, sign in ((1, 1.0), (2, -1.0)):
            out += _link(f"{g}finger{k}_link", gshapes[f"finger{k}"], grip.finger_mass, grip.pad_friction,
                         grip.pad_rolling_friction)
            out += _joint(
                f"{g}finger{k}_joint", "prismatic", g + "palm_link", f"{g}finger{k}_link", axis=(sign, 0, 0), limit=flim
            )
        out += _link(g + "tcp")
        out += _joint(g + "tcp_joint", "fixed", g + "palm_link", g + "tcp", (0.0, 0.0, grip.tcp_offset))
    out.append("</robot>")
    return "\n".join(out) + "\n"


def default_output(geometry: Any) -> Path:
    """Where the committed URDF lives (``robot.urdf`` of the config, relative to catkin_ws/src)."""
    return Path(geometry.robot.urdf)


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m pg_sim.robot.urdf_builder", description=__doc__.split("\n\n")[0])
    parser.add_argument("--config", help="geometry YAML (default: pg_policy's config/workspace.yaml)")
    parser.add_argument("--out", help="URDF file to write or check (default: the config's robot.urdf)")
    parser.add_argument("--check", action="store_true", help="exit 1 if the file differs from what the config gives")
    args = parser.parse_args(argv)


    geo = geometry_mod.load(args.config)
    text = build_urdf(geo)
    path = Path(args.out) if args.out else default_output(geo)
    if args.check:
        current = path.read_text() if path.is_file() else None
        if current != text:
            why = "is missing" if current is None else "differs from the geometry config"
            print(
                f"{path} {why}; regenerate it with: python -m pg_sim.robot.urdf_builder --out {path}",
                file=sys.stderr,
            )
            return 1
        print(f"{path} is up to date")
        return 0
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(text)
    print(f"wrote {path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
