"""pg_sim.robot.trajectory: JointTrajectory semantics, interpolation, replacement, validation and the velocity limit."""

from __future__ import annotations

import numpy as np
import pytest

from pg_sim.robot.trajectory import JointTrajectory, TrajectoryError, TrajectoryFollower, TrajectoryPoint, build_spline

NAMES = tuple(f"left_j{i}" for i in range(6))
DT = 1.0 / 240.0


def traj(points, names=NAMES, stamp=0.0) -> JointTrajectory:
    return JointTrajectory(tuple(names), tuple(TrajectoryPoint(*pt) for pt in points), stamp)


def follower(start=None, vmax=np.pi) -> TrajectoryFollower:
    return TrajectoryFollower(NAMES, np.zeros(6) if start is None else start, vmax, [-3.0] * 6, [3.0] * 6,
                              prefix="left_")


def run(f: TrajectoryFollower, t0: float, t1: float) -> tuple[float, np.ndarray]:
    t = t0
    q = f.reference
    while t < t1 - 1e-12:
        t += DT
        q, _ = f.update(t, DT)
    return t, q


def test_linear_interpolation_from_the_start_state():
    s = build_spline(traj([((1.0,) * 6, 1.0), ((0.0,) * 6, 3.0)]), NAMES, np.zeros(6))
    np.testing.assert_allclose(s.sample(0.5)[0], 0.5)
    np.testing.assert_allclose(s.sample(0.5)[1], 1.0)
    np.testing.assert_allclose(s.sample(2.0)[0], 0.5)
    np.testing.assert_allclose(s.sample(10.0)[0], 0.0)  # held after the end
    np.testing.assert_allclose(s.sample(-1.0)[0], 0.0)  # held before the start


def test_cubic_interpolation_with_velocities():
    s = build_spline(traj([((1.0,) * 6, 1.0, (0.0,) * 6)]), NAMES, np.zeros(6))
    assert s.velocities is not None
    q, qd = s.sample(0.5)
    np.testing.assert_allclose(q, 0.5)  # symmetric smoothstep
    np.testing.assert_allclose(qd, 1.5)  # peak velocity of the cubic = 1.5 x mean
    q, qd = s.sample(1e-6)
    assert abs(qd[0]) < 1e-4  # starts at rest
    # given non-zero velocities at an intermediate point, the spline passes through with that velocity
    s = build_spline(traj([((1.0,) * 6, 1.0, (2.0,) * 6), ((3.0,) * 6, 2.0, (0.0,) * 6)]), NAMES, np.zeros(6))
    q, qd = s.sample(1.0 - 1e-7)
    np.testing.assert_allclose(q, 1.0, atol=1e-5)
    np.testing.assert_allclose(qd, 2.0, atol=1e-4)


def test_first_point_at_time_zero_replaces_the_start_and_velocities_on_some_points_mean_linear():
    s = build_spline(traj([((0.2,) * 6, 0.0), ((1.0,) * 6, 1.0, (0.0,) * 6)]), NAMES, np.zeros(6))
    assert s.velocities is None
    np.testing.assert_allclose(s.sample(0.0)[0], 0.2)
    np.testing.assert_allclose(s.sample(0.5)[0], 0.6)


def test_partial_and_unprefixed_joint_names_hold_the_others():
    start = np.arange(6) * 0.1
    s = build_spline(traj([((1.0, 2.0), 1.0)], names=("j3", "left_j1")), NAMES, start, prefix="left_")
    goal = start.copy()
    goal[3], goal[1] = 1.0, 2.0
    np.testing.assert_allclose(s.goal, goal)


@pytest.mark.parametrize(
    ("trajectory", "match"),
    [
        (traj([((1.0,) * 6, 1.0)], names=("right_j0", *NAMES[1:])), "unknown joint"),
        (traj([((1.0,) * 6, 1.0)], names=(NAMES[0], *NAMES[:5])), "named twice"),
        (traj([((1.0,) * 6, 1.0), ((1.0,) * 6, 1.0)]), "not after"),
        (traj([((1.0,) * 6, -1.0)]), ">= 0"),
        (traj([((1.0,) * 5, 1.0)]), "5 positions for 6"),
        (traj([((1.0,) * 6, 1.0, (1.0,) * 2)]), "2 velocities"),
        (traj([((np.nan,) * 6, 1.0)]), "finite"),
        (traj([((0.0, 0.0, 5.0, 0.0, 0.0, 0.0), 1.0)]), "outside its limits"),
    ],
)
def test_invalid_trajectories_are_refused_and_change_nothing(trajectory, match):
    f = follower()
    f.set_trajectory(traj([((1.0,) * 6, 1.0)]), now=0.0)
    run(f, 0.0, 0.5)
    before = (f.spline, f.start_time, f.reference.copy())
    with pytest.raises(TrajectoryError, match=match):
        f.set_trajectory(trajectory, now=0.5)
    assert f.spline is before[0] and f.start_time == before[1]
    np.testing.assert_array_equal(f.reference, before[2])


def test_follower_reaches_the_goal_and_goes_inactive():
    f = follower()
    f.set_trajectory(traj([((0.5,) * 6, 1.0)]), now=0.0)
    assert f.active
    t, q = run(f, 0.0, 0.5)
    np.testing.assert_allclose(q, 0.25, atol=1e-9)
    t, q = run(f, t, 1.0 + DT)
    assert not f.active
    np.testing.assert_allclose(q, 0.5)
    np.testing.assert_allclose(f.update(t + DT, DT)[1], 0.0)  # held at rest


def test_velocity_limit_makes_a_too_fast_trajectory_late_not_wrong():
    f = follower(vmax=np.pi)
    f.set_trajectory(traj([((1.5,) * 6, 0.1)]), now=0.0)
    t, q = run(f, 0.0, 0.1)
    np.testing.assert_allclose(q, np.pi * t, rtol=1e-6)  # moved at the limit only
    assert f.velocity_limited and f.active
    steps = 0
    while f.active:
        t += DT
        q, qd = f.update(t, DT)
        assert np.all(np.abs(qd) <= np.pi + 1e-9)
        steps += 1
    assert t == pytest.approx(1.5 / np.pi, abs=2 * DT)
    np.testing.assert_allclose(q, 1.5)


def test_new_trajectory_replaces_the_current_one_from_the_present_reference():
    f = follower()
    f.set_trajectory(traj([((1.0,) * 6, 1.0)]), now=0.0)
    t, q_mid = run(f, 0.0, 0.5)
    f.set_trajectory(traj([((-1.0,) * 6, 1.0)]), now=t)
    q, _ = f.update(t + DT, DT)
    assert np.abs(q - q_mid).max() < 0.02  # no jump: starts where the old one was
    t, q = run(f, t + DT, t + 1.0 + 2 * DT)
    np.testing.assert_allclose(q, -1.0)


def test_stamp_sets_the_start_time_and_empty_trajectory_stops():
    f = follower()
    f.set_trajectory(traj([((1.0,) * 6, 1.0)], stamp=2.0), now=0.0)
    t, q = run(f, 0.0, 2.0)
    np.testing.assert_allclose(q, 0.0)  # holds until the stamp
    t, q = run(f, t, 2.5)
    np.testing.assert_allclose(q, 0.5, atol=0.01)
    f.set_trajectory(traj([]), now=t)
    assert not f.active
    q2, _ = f.update(t + 1.0, DT)
    np.testing.assert_allclose(q2, q)


def test_speed_scaling_keeps_the_joint_space_path():
    f = follower(vmax=1.0)
    goal = np.array([2.0, 0.5, -1.0, 0.0, 0.0, 0.25])
    f.set_trajectory(traj([(tuple(goal), 0.5)]), now=0.0)  # joint 0 would need 4 rad/s
    t = 0.0
    while f.active:
        t += DT
        q, qd = f.update(t, DT)
        np.testing.assert_allclose(q, goal * q[0] / 2.0, atol=1e-9)  # still on the straight joint-space line
        assert np.abs(qd).max() <= 1.0 + 1e-9
    assert t == pytest.approx(2.0, abs=2 * DT)
