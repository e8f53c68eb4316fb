"""The one robot URDF (DESIGN.md section 3): generated from the geometry config, committed, and exactly the DH model.

Checks the committed file against `build_urdf(load())`, its structure (names, limits, masses, inertias, DH joint
origins, gripper, camera frames), PyBullet forward kinematics against `pg_core.kinematics.dh_fk` on random
configurations, and that the camera sees only the table with the arms at home.
"""

from __future__ import annotations

import math
import shutil
import subprocess
import xml.etree.ElementTree as ET

import numpy as np
import pybullet as p
import pytest
from scipy.spatial.transform import Rotation

from pg_core.kinematics import arm_base_pose, dh_fk, rpy_matrix
from pg_sim.robot import urdf_builder
from pg_sim.robot.urdf_builder import ARM_LINKS, ARMS, build_urdf

POS_TOL = 1e-3  # m
ANG_TOL = 0.01  # rad


@pytest.fixture(scope="module")
def urdf_xml(urdf_geometry):
    return ET.fromstring(urdf_geometry.robot.urdf.read_text())


def _origin(el):
    o = el.find("origin")
    if o is None:
        return np.zeros(3), np.zeros(3)
    return (np.array([float(v) for v in o.get("xyz", "0 0 0").split()]),
            np.array([float(v) for v in o.get("rpy", "0 0 0").split()]))


def _rot_err(a: np.ndarray, b: np.ndarray) -> float:
    return float(Rotation.from_matrix(a[:3, :3] @ b[:3, :3].T).magnitude())


# ------------------------------------------------------------------------------------------------ generation
def test_committed_urdf_is_generated_from_config(urdf_geometry):
    committed = urdf_geometry.robot.urdf.read_text()
    assert committed == build_urdf(urdf_geometry), (
        "pushgrasp.urdf is stale: run `python -m pg_sim.robot.urdf_builder` after changing workspace.yaml"
    )


def test_cli_writes_and_checks(tmp_path, capsys):
    out = tmp_path / "robot.urdf"
    assert urdf_builder.main(["--out", str(out)]) == 0
    assert urdf_builder.main(["--check", "--out", str(out)]) == 0
    out.write_text(out.read_text().replace("pushgrasp", "other", 1))
    assert urdf_builder.main(["--check", "--out", str(out)]) == 1
    assert "regenerate" in capsys.readouterr().err
    assert urdf_builder.main(["--check", "--out", str(tmp_path / "missing.urdf")]) == 1
    assert urdf_builder.main(["--check"]) == 0  # the committed file


def test_inconsistent_gripper_config_is_rejected(urdf_geometry):
    import dataclasses

    bad = dataclasses.replace(urdf_geometry.gripper, finger_size=(0.01, 0.02, 0.03))
    with pytest.raises(ValueError, match="finger_size"):
        build_urdf(dataclasses.replace(urdf_geometry, gripper=bad))


# ------------------------------------------------------------------------------------------------- structure
def test_tree_names_and_plain_urdf(urdf_xml, urdf_geometry):
    links = [el.get("name") for el in urdf_xml.findall("link")]
    joints = urdf_xml.findall("joint")
    assert len(links) == len(set(links)) and len(joints) == len({j.get("name") for j in joints})
    children = [j.find("child").get("link") for j in joints]
    assert sorted(children) == sorted(n for n in links if n != "world"), "every link but world has one parent"
    assert {j.find("parent").get("link") for j in joints} <= set(links)
    assert urdf_xml.find(".//mesh") is None and "xacro" not in ET.tostring(urdf_xml).decode()
    expected = {"world", "table", "camera_link", "camera_color_optical_frame"}
    for arm in ARMS:
        expected |= {f"{arm}_{n}" for n in ("base_link", *ARM_LINKS, "tool0", "gripper_palm_link",
                                           "gripper_finger1_link", "gripper_finger2_link", "gripper_tcp")}
    assert expected <= set(links)
    names = {j.get("name"): j for j in joints}
    for arm in ARMS:
        for n in urdf_geometry.robot.joint_names:
            assert names[f"{arm}_{n}"].get("type") == "revolute"
        for k in (1, 2):
            assert names[f"{arm}_gripper_finger{k}_joint"].get("type") == "prismatic"
    movable = [j for j in joints if j.get("type") != "fixed"]
    assert len(movable) == 2 * (6 + 2)


def test_arm_joints_follow_dh_and_limits(urdf_xml, urdf_geometry):
    r = urdf_geometry.robot
    joints = {j.get("name"): j for j in urdf_xml.findall("joint")}
    for arm in ARMS:
        base = joints[f"{arm}_base_joint"]
        xyz, rpy = _origin(base)
        assert base.find("parent").get("link") == "world"
        np.testing.assert_allclose(xyz, r.arms[arm].xyz, atol=1e-9)
        np.testing.assert_allclose(rpy_matrix(rpy), rpy_matrix(r.arms[arm].rpy), atol=1e-9)
        parent = f"{arm}_base_link"
        for i, n in enumerate(r.joint_names):
            j = joints[f"{arm}_{n}"]
            assert j.find("parent").get("link") == parent
            assert j.find("child").get("link") == f"{arm}_{ARM_LINKS[i]}"
            xyz, rpy = _origin(j)
            want_xyz = (0, 0, 0) if i == 0 else (r.dh_a[i - 1], 0, r.dh_d[i - 1])
            want_rpy = (0, 0, 0) if i == 0 else (r.dh_alpha[i - 1], 0, 0)
            np.testing.assert_allclose(xyz, want_xyz, atol=1e-9)
            np.testing.assert_allclose(rpy, want_rpy, atol=1e-9)
            assert j.find("axis").get("xyz").split() == ["0", "0", "1"]
            lim = j.find("limit")
            assert float(lim.get("lower")) == pytest.approx(r.joint_lower[i])
            assert float(lim.get("upper")) == pytest.approx(r.joint_upper[i])
            assert float(lim.get("velocity")) == pytest.approx(r.joint_velocity_limit)
            assert float(lim.get("effort")) == pytest.approx(r.joint_effort_limit[i])
            parent = f"{arm}_{ARM_LINKS[i]}"
        tool = joints[f"{arm}_tool0_joint"]
        xyz, rpy = _origin(tool)
        assert tool.find("parent").get("link") == f"{arm}_wrist_3_link"
        np.testing.assert_allclose(xyz, (r.dh_a[5], 0, r.dh_d[5]), atol=1e-9)
        np.testing.assert_allclose(rpy, (r.dh_alpha[5], 0, 0), atol=1e-9)


def test_gripper_joints(urdf_xml, urdf_geometry):
    g = urdf_geometry.gripper
    joints = {j.get("name"): j for j in urdf_xml.findall("joint")}
    for arm in ARMS:
        for k, axis in ((1, 1.0), (2, -1.0)):
            j = joints[f"{arm}_gripper_finger{k}_joint"]
            np.testing.assert_allclose([float(v) for v in j.find("axis").get("xyz").split()], (axis, 0, 0))
            lim = j.find("limit")
            assert float(lim.get("lower")) == 0.0
            assert float(lim.get("upper")) == pytest.approx(g.max_opening / 2)
            assert float(lim.get("effort")) == pytest.approx(g.finger_force)
            assert float(lim.get("velocity")) == pytest.approx(g.finger_speed)
            assert j.find("mimic") is None  # each finger is driven on its own (PyBullet ignores <mimic>)
        xyz, rpy = _origin(joints[f"{arm}_gripper_tcp_joint"])
        np.testing.assert_allclose(xyz, (0, 0, g.tcp_offset))


def test_masses_and_inertias(urdf_xml, urdf_geometry):
    masses = {}
    for link in urdf_xml.findall("link"):
        inertial = link.find("inertial")
        if inertial is None:
            assert link.get("name") == "world"  # KDL wants an inertia-free root
            continue
        m = float(inertial.find("mass").get("value"))
        ine = inertial.find("inertia")
        full = np.array([[float(ine.get("ixx")), float(ine.get("ixy")), float(ine.get("ixz"))],
                         [float(ine.get("ixy")), float(ine.get("iyy")), float(ine.get("iyz"))],
                         [float(ine.get("ixz")), float(ine.get("iyz")), float(ine.get("izz"))]])
        ev = np.linalg.eigvalsh(full)
        assert m > 0 and ev.min() > 0, link.get("name")
        assert ev[0] + ev[1] >= ev[2] * (1 - 1e-9), f"{link.get('name')}: inertia violates the triangle inequality"
        masses[link.get("name")] = m
    r, g = urdf_geometry.robot, urdf_geometry.gripper
    for arm in ARMS:
        for name, m in zip(ARM_LINKS, r.link_masses, strict=True):
            assert masses[f"{arm}_{name}"] == pytest.approx(m)
        assert masses[f"{arm}_gripper_palm_link"] == pytest.approx(g.palm_mass)
        assert masses[f"{arm}_gripper_finger1_link"] == pytest.approx(g.finger_mass)
        assert masses[f"{arm}_tool0"] < 0.01 and masses[f"{arm}_gripper_tcp"] < 0.01


def test_check_urdf_tool(urdf_geometry):
    assert shutil.which("check_urdf"), "check_urdf not found: Debian liburdfdom-tools (scripts/apt-packages.txt)"
    out = subprocess.run(["check_urdf", str(urdf_geometry.robot.urdf)], capture_output=True, text=True, timeout=60)
    assert out.returncode == 0, out.stdout + out.stderr
    assert "Successfully Parsed" in out.stdout
    assert "root Link: world" in out.stdout


def test_the_kinematic_tree_read_as_plain_xml(urdf_geometry):
    # a reader independent of urdfdom and PyBullet: one tree rooted at `world`, 16 moving joints (2 x 6 arm joints,
    # 2 x 2 fingers)
    root = ET.fromstring(urdf_geometry.robot.urdf.read_text())
    links = {link.get("name") for link in root.findall("link")}
    joints = root.findall("joint")
    children = [j.find("child").get("link") for j in joints]
    assert len(children) == len(set(children)) and set(children) <= links
    assert links - set(children) == {"world"}
    assert len([j for j in joints if j.get("type") != "fixed"]) == 16


# ---------------------------------------------------------------------------------------------------- PyBullet
def test_pybullet_dynamics_and_limits(urdf_robot, urdf_geometry):
    rb, r = urdf_robot, urdf_geometry.robot
    for arm in ARMS:
        for i, j in enumerate(rb.arm_joints[arm]):
            info = p.getJointInfo(rb.body, j, physicsClientId=rb.cid)
            assert (info[8], info[9]) == pytest.approx((r.joint_lower[i], r.joint_upper[i]))
            assert info[10] == pytest.approx(r.joint_effort_limit[i])
            assert info[11] == pytest.approx(r.joint_velocity_limit)
            mass = p.getDynamicsInfo(rb.body, j, physicsClientId=rb.cid)[0]
            assert mass == pytest.approx(r.link_masses[i])
        for frame in ("tool0", "gripper_tcp"):  # no default 1 kg on frame-only links
            assert p.getDynamicsInfo(rb.body, rb.link[f"{arm}_{frame}"], physicsClientId=rb.cid)[0] < 0.01
        for k in (1, 2):  # rubber pads: the config's friction, not PyBullet's default 0.5
            finger = p.getDynamicsInfo(rb.body, rb.link[f"{arm}_gripper_finger{k}_link"], physicsClientId=rb.cid)
            assert finger[1] == pytest.approx(urdf_geometry.gripper.pad_friction)
        palm = p.getDynamicsInfo(rb.body, rb.link[f"{arm}_gripper_palm_link"], physicsClientId=rb.cid)
        assert palm[1] == pytest.approx(0.5)


def test_pybullet_fk_equals_dh(urdf_robot, urdf_geometry):
    """200 seeded random configurations per arm: PyBullet tool0 = world<-base * dh_fk(q) (1 mm, 0.01 rad)."""
    rb, r = urdf_robot, urdf_geometry.robot
    rng = np.random.default_rng(2024)
    lo, hi = np.array(r.joint_lower), np.array(r.joint_upper)
    try:
        for arm in ARMS:
            base = arm_base_pose(r.arms[arm])
            qs = [np.zeros(6)] + [rng.uniform(lo, hi) for _ in range(199)]
            for q in qs:
                rb.set_arm(arm, q)
                want = base @ dh_fk(q, r.dh_d, r.dh_a, r.dh_alpha)
                got = rb.frame(f"{arm}_tool0")
                assert np.linalg.norm(got[:3, 3] - want[:3, 3]) < POS_TOL, (arm, q)
                assert _rot_err(got, want) < ANG_TOL, (arm, q)
                tcp = rb.frame(f"{arm}_gripper_tcp")
                np.testing.assert_allclose(tcp[:3, 3], want[:3, 3] + want[:3, 2] * urdf_geometry.gripper.tcp_offset,
                                           atol=1e-6)
    finally:
        rb.home_all()


def test_zero_configuration_is_dh_zero(urdf_robot, urdf_geometry):
    rb, r = urdf_robot, urdf_geometry.robot
    try:
        for arm in ARMS:
            rb.set_arm(arm, np.zeros(6))
            base = arm_base_pose(r.arms[arm])
            # at q = 0 the UR arm lies stretched along -x of base_link at shoulder height (+ wrist offsets)
            want = base @ np.array([r.dh_a[1] + r.dh_a[2], -(r.dh_d[3] + r.dh_d[5]), r.dh_d[0] - r.dh_d[4], 1.0])
            np.testing.assert_allclose(rb.frame(f"{arm}_tool0")[:3, 3], want[:3], atol=1e-6)
    finally:
        rb.home_all()


def test_camera_frames(urdf_robot, urdf_geometry):
    optical = urdf_robot.frame("camera_color_optical_frame")
    np.testing.assert_allclose(optical, urdf_geometry.camera.pose, atol=1e-6)
    link = urdf_robot.frame("camera_link")
    np.testing.assert_allclose(link[:3, 3], optical[:3, 3], atol=1e-9)
    # REP 103 body frame: x forward (the optical axis), y left (-optical x), z up (-optical y)
    np.testing.assert_allclose(link[:3, 0], optical[:3, 2], atol=1e-6)
    np.testing.assert_allclose(link[:3, 1], -optical[:3, 0], atol=1e-6)
    np.testing.assert_allclose(link[:3, 2], -optical[:3, 1], atol=1e-6)


def _ray(rb, a, b):
    hit = p.rayTest(list(a), list(b), physicsClientId=rb.cid)[0]
    return hit[0], hit[1], np.array(hit[3])


def test_table_top_is_world_z0(urdf_robot, urdf_geometry):
    rb = urdf_robot
    ground = rb.ground
    p.resetBasePositionAndOrientation(ground, [0, 0, -100], [0, 0, 0, 1], physicsClientId=rb.cid)
    try:
        for x, y in ((0.1, 0.1), (-0.224, 0.224), (0.224, -0.224), (0.5, 0.0)):
            body, link, pos = _ray(rb, (x, y, 0.3), (x, y, -1.0))
            assert (body, link) == (rb.body, rb.link["table"])
            assert pos[2] == pytest.approx(0.0, abs=1e-6)
        sx, sy, sz = urdf_geometry.table.size
        cx, cy = urdf_geometry.table.center_xy
        _, _, under = _ray(rb, (cx + 0.3, cy + 0.3, -1.0), (cx + 0.3, cy + 0.3, 0.5))
        assert under[2] == pytest.approx(-sz, abs=1e-6)
        _, _, edge = _ray(rb, (cx + sx, cy + 0.3, -0.01), (cx, cy + 0.3, -0.01))
        assert edge[0] == pytest.approx(cx + sx / 2, abs=1e-6)
    finally:
        p.resetBasePositionAndOrientation(ground, [0, 0, -0.5], [0, 0, 0, 1], physicsClientId=rb.cid)


@pytest.mark.parametrize("q1,q2", [(0.01, 0.03), (0.0425, 0.0425), (0.02, 0.0)])
def test_gripper_fingers_geometry(urdf_robot, urdf_geometry, q1, q2):
    """Inner finger faces at tool0 x = +q1 and -q2 (opening q1 + q2), fingertips at tool0 z = tcp_offset."""
    rb, g = urdf_robot, urdf_geometry.gripper
    arm = "left"
    f1, f2 = rb.joint[f"{arm}_gripper_finger1_joint"], rb.joint[f"{arm}_gripper_finger2_joint"]
    p.resetJointState(rb.body, f1, q1, physicsClientId=rb.cid)
    p.resetJointState(rb.body, f2, q2, physicsClientId=rb.cid)
    try:
        t = rb.frame(f"{arm}_tool0")

        def world(v):
            return (t @ np.array([*v, 1.0]))[:3]

        def local(v):
            return (np.linalg.inv(t) @ np.array([*v, 1.0]))[:3]

        zmid = 0.5 * (g.palm_size[2] + g.tcp_offset)
        mid = 0.5 * (q1 - q2)
        body, link, hit = _ray(rb, world((mid, 0, zmid)), world((0.2, 0, zmid)))
        assert link == rb.link[f"{arm}_gripper_finger1_link"]
        assert local(hit)[0] == pytest.approx(q1, abs=1e-6)
        body, link, hit = _ray(rb, world((mid, 0, zmid)), world((-0.2, 0, zmid)))
        assert link == rb.link[f"{arm}_gripper_finger2_link"]
        assert local(hit)[0] == pytest.approx(-q2, abs=1e-6)
        # fingertip (bottom face) at tcp_offset; finger root at the palm
        x1 = q1 + g.finger_size[0] / 2
        body, link, hit = _ray(rb, world((x1, 0, g.tcp_offset + 0.05)), world((x1, 0, 0.0)))
        assert link == rb.link[f"{arm}_gripper_finger1_link"]
        assert local(hit)[2] == pytest.approx(g.tcp_offset, abs=1e-6)
        body, link, hit = _ray(rb, world((0, 0.2, 0.5 * g.palm_size[2])), world((0, 0, 0.5 * g.palm_size[2])))
        assert link == rb.link[f"{arm}_gripper_palm_link"]
        assert local(hit)[1] == pytest.approx(g.palm_size[1] / 2, abs=1e-6)
        np.testing.assert_allclose(local(rb.frame(f"{arm}_gripper_tcp")[:3, 3]), (0, 0, g.tcp_offset), atol=1e-6)
    finally:
        p.resetJointState(rb.body, f1, 0.0, physicsClientId=rb.cid)
        p.resetJointState(rb.body, f2, 0.0, physicsClientId=rb.cid)


def test_camera_sees_only_the_table_with_arms_at_home(urdf_robot):
    """The mount, the camera body and both arms at home stay out of the image: every pixel is table."""
    urdf_robot.home_all()
    seg = urdf_robot.segmentation()
    seen = {int(v): int(n) for v, n in zip(*np.unique(seg, return_counts=True), strict=True)}
    assert seen == {urdf_robot.link["table"]: seg.size}, seen


def test_rpy_round_trip():
    from pg_core.kinematics import matrix_rpy

    rng = np.random.default_rng(3)
    for _ in range(100):
        rpy = rng.uniform(-math.pi, math.pi, 3) * np.array([1, 0.5, 1])
        np.testing.assert_allclose(rpy_matrix(matrix_rpy(rpy_matrix(rpy))), rpy_matrix(rpy), atol=1e-12)
        np.testing.assert_allclose(rpy_matrix(rpy), Rotation.from_euler("xyz", rpy).as_matrix(), atol=1e-12)


def test_the_configured_pad_friction_reaches_the_loaded_fingers(urdf_geometry):
    # a geometry config copy changes the simulated pads without a regenerated URDF; the URDF carries a rolling
    # friction only when one is configured
    import dataclasses

    from pg_sim.robot.robot_model import load_robot

    grip = dataclasses.replace(urdf_geometry.gripper, pad_friction=1.7, pad_rolling_friction=0.05)
    geometry = dataclasses.replace(urdf_geometry, gripper=grip)
    cid = p.connect(p.DIRECT)
    try:
        index = load_robot(cid, geometry)
        for arm in index.arms.values():
            for finger in arm.fingers:
                info = p.getDynamicsInfo(index.body, finger, physicsClientId=cid)
                assert (info[1], info[6]) == pytest.approx((1.7, 0.05))  # lateral, rolling friction
            palm = p.getDynamicsInfo(index.body, arm.palm, physicsClientId=cid)
            assert palm[6] == pytest.approx(0.0)
    finally:
        p.disconnect(cid)
    assert "<rolling_friction" not in build_urdf(urdf_geometry)
    assert build_urdf(geometry).count('<rolling_friction value="0.05"/>') == 4  # two fingers per arm
