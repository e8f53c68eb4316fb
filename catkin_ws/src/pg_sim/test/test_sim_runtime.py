"""pg_sim.runtime.sim_runtime: the sim node's ROS-free core in PyBullet DIRECT worlds (trajectories under physics,
grippers, joint states, camera, scene state, resets that validate first, answer at rest and refuse while an arm moves,
output rates, pacing, thread-safe submissions)."""

from __future__ import annotations

import threading

import numpy as np
import pytest

from pg_core.user_text import ECHOED_CHARS
from pg_sim.robot.trajectory import JointTrajectory, TrajectoryPoint
from pg_sim.runtime.runtime_types import ResetRequest, RuntimeConfig
from pg_sim.runtime.sim_runtime import MAX_MESSAGE, SimRuntime
from pg_sim.scenes.scene import SceneError
from pg_sim.world.pacer import Pacer
from pg_sim.world.sensor_data import CLOUD_DTYPE

FAST = dict(real_time_factor=0.0, idle_real_time_factor=0.0)
ESCAPE = "../" * 16 + "etc/passwd"  # a scene path that climbs out of any working directory


@pytest.fixture(scope="module")
def rt(tmp_path_factory):
    folders = (str(tmp_path_factory.getbasetemp()),)  # reset requests may name files under pytest's tmp_path
    runtime = SimRuntime(RuntimeConfig(**FAST, scene_folders=folders))
    yield runtime
    runtime.close()


@pytest.fixture()
def fresh(rt):
    """The shared runtime back on packed/case01 with arms at home."""
    assert rt.reset(ResetRequest("packed/case01")).success
    return rt


def poses(rt: SimRuntime) -> dict[str, tuple]:
    return {o.name: o.position for o in rt.scene_state().objects}


def left_traj(rt: SimRuntime, goal, t: float, velocities=None) -> JointTrajectory:
    pt = TrajectoryPoint(tuple(float(v) for v in goal), t, tuple(velocities) if velocities is not None else ())
    return JointTrajectory(rt.arms["left"].joint_names, (pt,))


def run_until_idle(rt: SimRuntime, max_time: float = 10.0) -> float:
    t0 = rt.sim_time
    while rt.sim_time - t0 < max_time:
        if not rt.step().busy and rt.sim_time - t0 > 0.05:
            break
    return rt.sim_time - t0


def test_joint_state_names_and_home(fresh):
    js = fresh.joint_state()
    assert len(js.names) == 16 and len(set(js.names)) == 16
    assert js.names[:8] == ("left_shoulder_pan_joint", "left_shoulder_lift_joint", "left_elbow_joint",
                            "left_wrist_1_joint", "left_wrist_2_joint", "left_wrist_3_joint",
                            "left_gripper_finger1_joint", "left_gripper_finger2_joint")
    assert js.names[8].startswith("right_")
    home = fresh.geometry.robot.arms["left"].home
    np.testing.assert_allclose(js.positions[:6], home, atol=2e-3)
    assert js.positions[6] + js.positions[7] == pytest.approx(fresh.geometry.gripper.max_opening, abs=2e-3)


def test_trajectory_moves_the_arm_under_physics(fresh):
    home = fresh.arm_joints("left")
    goal = home + np.array([0.4, 0.2, -0.2, 0.2, 0.3, 0.5])
    fresh.submit_trajectory("left", left_traj(fresh, goal, 1.0, velocities=np.zeros(6)))
    took = run_until_idle(fresh)
    assert 1.0 <= took < 1.5
    np.testing.assert_allclose(fresh.arm_joints("left"), goal, atol=2e-3)
    np.testing.assert_allclose(fresh.arm_joints("right"), fresh.geometry.robot.arms["right"].home, atol=2e-3)


def test_fast_trajectory_is_held_to_the_velocity_limit(fresh):
    home = fresh.arm_joints("left")
    goal = home + np.array([1.2, 0, 0, 0, 0, 0])
    fresh.command_trajectory("left", left_traj(fresh, goal, 0.1))
    peak = 0.0
    t0 = fresh.sim_time
    while fresh.arms["left"].follower.active:
        fresh.step()
        peak = max(peak, float(np.abs(fresh.joint_state().velocities[:6]).max()))
    assert fresh.sim_time - t0 == pytest.approx(1.2 / np.pi, abs=0.02)
    assert peak <= np.pi * 1.05
    run_until_idle(fresh)
    np.testing.assert_allclose(fresh.arm_joints("left"), goal, atol=2e-3)


def test_refused_trajectory_is_reported_and_changes_nothing(fresh):
    fresh.submit_trajectory("left", JointTrajectory(("right_elbow_joint",), (TrajectoryPoint((0.0,), 1.0),)))
    fresh.submit_trajectory("middle", JointTrajectory(("elbow_joint",), (TrajectoryPoint((0.0,), 1.0),)))
    wall_stamp = JointTrajectory(("left_elbow_joint",), (TrajectoryPoint((0.0,), 1.0),), stamp=1.7e9)
    fresh.submit_trajectory("left", wall_stamp)
    out = fresh.step()
    assert len(out.messages) == 3 and "unknown joint" in out.messages[0] and "unknown arm" in out.messages[1]
    assert "use_sim_time" in out.messages[2]
    assert not fresh.arms["left"].follower.active


def test_gripper_opening_is_clamped_and_reached(fresh):
    assert fresh.command_gripper("right", -0.5) == 0.0
    run_until_idle(fresh)
    assert fresh.gripper_opening("right") < 2e-3
    fresh.submit_gripper("right", 0.04)
    run_until_idle(fresh)
    assert fresh.gripper_opening("right") == pytest.approx(0.04, abs=2e-3)
    assert fresh.command_gripper("right", 1.0) == fresh.geometry.gripper.max_opening
    with pytest.raises(ValueError):
        fresh.command_gripper("right", float("nan"))


def test_scene_state_ground_truth(fresh):
    s = fresh.scene_state()
    assert s.scene == fresh.world.scene.name and s.target == "green" and s.target_in_workspace
    assert len(s.objects) == len(fresh.world.scene.objects)
    (target,) = (o for o in s.objects if o.target)
    assert target.color_name == "green" and target.rgb == (89, 161, 79)
    for o in s.objects:
        assert o.in_workspace and o.shape in {"cube", "rect", "triangle", "arch", "cylinder", "half_cube",
                                              "half_cylinder"}
        assert np.linalg.norm(o.quaternion) == pytest.approx(1.0)
    assert len(fresh.markers()) >= len(s.objects)


@pytest.mark.parametrize(
    ("request_", "field", "match"),
    [
        (ResetRequest("packed/case99"), "scene", "not found"),
        (ResetRequest(""), "scene", "empty scene"),
        (ResetRequest("random", 0, 1), "num_objects", "num_objects"),
        (ResetRequest("random-5", 6, 1), "num_objects", "names 5 objects"),
        (ResetRequest("random", 10, -5), "seed", "must be a non-negative integer, got -5"),
        (ResetRequest("packed/case01", 0, -5), "seed", "must be a non-negative integer, got -5"),
        (ResetRequest("random", -3, 1), "num_objects", "must be a non-negative integer, got -3"),
        (ResetRequest("random", 500, 1), "num_objects", "a random scene needs num_objects in [1, 40], got 500"),
        (ResetRequest(ESCAPE), "scene",  # relative to the working directory, whichever it is
         f"'{ESCAPE}' (resolved: '/etc/passwd') is outside the allowed scene folders"),
        (ResetRequest("/etc/passwd"), "scene", "'/etc/passwd' is outside the allowed scene folders"),
        (ResetRequest("x" * 100000), "scene", "100000 characters, at most 1024"),
        (ResetRequest("x" * 1000), "scene", "'xxxx"),
    ],
)
def test_refused_reset_changes_nothing(fresh, request_, field, match):
    fresh.step()
    before, name, t, resets = poses(fresh), fresh.world.scene.name, fresh.sim_time, fresh.scene_resets
    result = fresh.reset(request_)
    assert not result.success and match in result.message and "scene unchanged" in result.message, result.message
    assert result.message.startswith(f"reset refused, scene unchanged: {field}"), result.message
    assert len(result.message) <= MAX_MESSAGE
    assert fresh.world.scene.name == name and poses(fresh) == before and fresh.sim_time == t
    assert fresh.scene_resets == resets



@pytest.mark.parametrize("scene", ["s" * 10_000, "packed/" + "s" * 1000])
def test_a_huge_scene_name_is_repeated_cut_with_its_length(fresh, scene):
    result = fresh.reset(ResetRequest(scene))
    assert not result.success and len(result.message) < 300, result.message
    assert f"{scene[:ECHOED_CHARS]!r}\u2026({len(scene)} chars)" in result.message, result.message

def test_bad_yaml_files_are_refused(fresh, tmp_path):
    bad = tmp_path / "bad.yaml"
    bad.write_text("name: bad\nobjects:\n  - shape: blob\n    color: green\n    pose: [0, 0, 0.02, 0, 0, 0]\n")
    missing_mesh = tmp_path / "mesh.yaml"
    missing_mesh.write_text("objects:\n  - shape: mesh\n    mesh: nope.obj\n    color: green\n"
                            "    pose: [0, 0, 0, 0, 0, 0]\n")
    before = poses(fresh)
    huge = tmp_path / "huge.yaml"
    huge.write_text("objects:\n  - {shape: cube, size: [1e6, 1e6, 1e6], color: green, pose: [0, 0, 0, 0, 0, 0]}\n")
    escape = tmp_path / "escape.yaml"
    escape.write_text("objects:\n  - shape: mesh\n    mesh: ../../../../../../../../../etc/passwd\n    color: green\n"
                      "    pose: [0, 0, 0, 0, 0, 0]\n")
    for path, match in ((bad, "unknown shape"), (missing_mesh, "mesh file not found"),
                        (huge, "size [1000000.0, 1000000.0, 1000000.0]: extent 1e+06 m is larger than max_object_size"),
                        (escape, "outside the allowed mesh folders")):
        result = fresh.reset(ResetRequest(str(path)))
        assert not result.success and match in result.message, result.message
        assert result.message.startswith(f"reset refused, scene unchanged: scene: {path}:"), result.message
    assert poses(fresh) == before


def test_reset_to_file_random_and_named_scenes(fresh, tmp_path):
    path = tmp_path / "two.yaml"
    path.write_text("name: two\nobjects:\n  - {shape: cube, color: green, pose: [0, 0, 0.0225, 0, 0, 0]}\n"
                    "  - {shape: cylinder, color: red, pose: [0.1, 0, 0.0225, 0, 0, 0]}\n")
    r = fresh.reset(ResetRequest(str(path)))
    assert r.success and r.scene_name == "two" and r.num_objects == 2 and r.target == "green"
    r = fresh.reset(ResetRequest("random", 4, 7))
    assert r.success and r.num_objects == 4
    first = poses(fresh)
    assert fresh.reset(ResetRequest("random-4", 0, 7)).success
    assert poses(fresh).keys() == first.keys()
    np.testing.assert_allclose(np.array(list(poses(fresh).values())), np.array(list(first.values())), atol=1e-6)
    r = fresh.reset(ResetRequest("household/case11"))
    assert r.success and r.scene_name == "household/case11" and r.num_objects == 5
    s = fresh.scene_state()
    assert s.scene == "household/case11" and {o.name for o in s.objects if o.target} == {"milk_box_0"}


def test_reset_is_refused_while_an_arm_executes_a_trajectory(fresh):
    home = fresh.arm_joints("left")
    fresh.submit_trajectory("left", left_traj(fresh, home + 0.3, 1.0))
    fresh.submit_gripper("left", 0.0)
    fresh.run_for(0.3)
    before, resets = poses(fresh), fresh.scene_resets
    result = fresh.reset(ResetRequest("packed/case02"))
    assert not result.success and result.message.startswith("busy: arm left is executing a trajectory"), result.message
    assert fresh.world.scene.name == "packed/case01" and poses(fresh) == before and fresh.scene_resets == resets
    assert fresh.arms["left"].follower.active  # the trajectory goes on
    pending = fresh.submit_reset(ResetRequest("packed/case02"))  # the queued path (the ROS service) alike
    fresh.step()
    assert not pending.wait(0).success and "busy: arm left" in pending.wait(0).message
    run_until_idle(fresh)
    np.testing.assert_allclose(fresh.arm_joints("left"), home + 0.3, atol=2e-3)


def test_reset_homes_arms_and_counts_successful_resets(fresh):
    home = fresh.arm_joints("left")
    fresh.submit_trajectory("left", left_traj(fresh, home + 0.3, 0.5))
    fresh.submit_gripper("left", 0.0)
    run_until_idle(fresh)
    resets = fresh.scene_resets
    result = fresh.reset(ResetRequest("packed/case02"))
    assert result.success and result.resets == resets + 1 == fresh.scene_resets
    fresh.run_for(0.2)
    np.testing.assert_allclose(fresh.arm_joints("left"), home, atol=2e-3)
    assert fresh.gripper_opening("left") == pytest.approx(fresh.geometry.gripper.max_opening, abs=2e-3)
    assert fresh.reset(ResetRequest("packed/case02")).resets == resets + 2  # the same scene again counts too
    assert not fresh.reset(ResetRequest("packed/nope")).success and fresh.scene_resets == resets + 2


def test_submit_reset_from_another_thread(fresh):
    results = {}

    def call():
        pending = fresh.submit_reset(ResetRequest("packed/case03"))
        results["r"] = pending.wait(timeout=20.0)

    th = threading.Thread(target=call)
    th.start()
    while th.is_alive():
        fresh.step()
    th.join()
    assert results["r"] is not None and results["r"].success and fresh.world.scene.name == "packed/case03"


def test_output_rates_and_camera_reuse(fresh):
    run_until_idle(fresh)
    outs = fresh.run_for(1.0)
    assert sum(o.joint_state is not None for o in outs) == pytest.approx(50, abs=1)
    caps = [o.camera for o in outs if o.camera is not None]
    assert len(caps) == pytest.approx(2, abs=1)
    assert sum(o.scene_state is not None for o in outs) == pytest.approx(2, abs=1)
    cap = fresh.capture(force=True)
    assert cap.rendered and cap.color.shape == (480, 640, 3) and cap.color.dtype == np.uint8
    assert cap.depth.dtype == np.float32 and cap.cloud.shape == (480, 640) and cap.cloud.dtype == CLOUD_DTYPE
    assert np.isfinite(cap.cloud["z"]).mean() > 0.99  # the table fills the view
    again = fresh.capture()  # nothing moved: the render is re-used under a new stamp
    assert not again.rendered and again.seq == cap.seq and again.cloud is cap.cloud
    fresh.submit_gripper("left", 0.0)
    fresh.run_for(0.1)
    assert fresh.capture().seq == cap.seq + 1  # something moved: rendered anew


def test_unknown_initial_scene_raises():
    with pytest.raises(SceneError, match="not found"):
        SimRuntime(RuntimeConfig(scene="packed/nope", **FAST))


class FakeClock:
    def __init__(self) -> None:
        self.t = 100.0

    def __call__(self) -> float:
        return self.t

    def sleep(self, s: float) -> None:
        self.t += s


def test_pacer_throttles_idle_and_not_busy():
    clock = FakeClock()
    pacer = Pacer(busy_factor=0.0, idle_factor=1.0, clock=clock, sleep=clock.sleep)
    dt = 1 / 240
    sim = 0.0
    for _ in range(240):  # idle: one sim second takes one wall second
        sim += dt
        clock.t += 1e-4  # cost of a step
        pacer.pace(sim, busy=False)
    assert clock.t - 100.0 == pytest.approx(1.0, abs=0.01)
    start = clock.t
    for _ in range(240):  # busy with factor 0: no sleeping at all
        sim += dt
        clock.t += 1e-4
        assert pacer.pace(sim, busy=True) == 0.0
    assert clock.t - start == pytest.approx(0.024)
    pacer = Pacer(busy_factor=2.0, idle_factor=1.0, clock=clock, sleep=clock.sleep)
    start = clock.t
    for _ in range(481):  # busy at most 2x real time
        sim += dt
        pacer.pace(sim, busy=True)
    assert clock.t - start == pytest.approx(1.0, abs=0.01)
    clock.t += 5.0  # fell behind (slow steps): re-anchor, no catch-up burst and no long sleep afterwards
    sim += dt
    assert pacer.pace(sim, busy=True) == 0.0
    sim += 10 * dt
    assert pacer.pace(sim, busy=True) == pytest.approx(5 * dt)


def test_objects_outside_the_workspace_or_off_the_table_are_left(fresh):
    from pg_sim.runtime.object_activity import FALLEN_Z
    from pg_sim.scenes.objects import set_object_pose

    bodies = list(fresh.world.objects)
    target = fresh.world.target_id
    other = next(b for b in bodies if b != target)
    set_object_pose(fresh.world.client, target, (0.0, 0.35, 0.05, 0.0, 0.0, 0.0))  # on the table, out of the box
    set_object_pose(fresh.world.client, other, (0.0, 1.5, 0.3, 0.0, 0.0, 0.0))  # beyond the table's edge
    took = run_until_idle(fresh, max_time=10.0)
    assert took < 5.0  # the fallen object was frozen below the table: it does not keep the sim busy
    s = fresh.scene_state()
    assert len(s.objects) == len(bodies) and not s.target_in_workspace and s.target == "green"
    by_name = {o.name: o for o in s.objects}
    assert not by_name[fresh.world.objects[target].name].in_workspace
    fallen = by_name[fresh.world.objects[other].name]
    assert not fallen.in_workspace and fallen.position[2] < FALLEN_Z
    z = fallen.position[2]
    fresh.run_for(1.0)
    assert {o.name: o for o in fresh.scene_state().objects}[fallen.name].position[2] == pytest.approx(z)
