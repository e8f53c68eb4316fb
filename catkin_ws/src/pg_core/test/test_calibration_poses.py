"""pg_core.calibration_poses: the board poses a calibration visits are reachable from each arm's home, every joint
motion of the plan (the way back included) keeps the arm above the table, and a motion through the table is seen."""

from __future__ import annotations

import numpy as np
import pytest

from pg_core.calibration_poses import (
    MIN_LINK_Z_M,
    board_mount,
    board_poses,
    calibration_plan,
    joint_path_clear,
    link_heights,
)
from pg_core.geometry import load
from pg_core.kinematics import tool_fk


@pytest.fixture(scope="module")
def geometry():
    return load()


@pytest.mark.parametrize("arm", ["left", "right"])
def test_the_plan_from_home_visits_every_pose_on_clear_paths(geometry, arm):
    home = np.asarray(geometry.robot.arms[arm].home, dtype=np.float64)
    plan = calibration_plan(geometry, arm, home, poses=12)
    assert len(plan) == 12
    for a, b in zip([home, *plan], [*plan, home], strict=True):
        assert joint_path_clear(geometry, arm, a, b)
    # each target shows the board where board_poses puts it
    for q, want in zip(plan, board_poses(12), strict=True):
        got = tool_fk(geometry, arm, q) @ board_mount()
        assert np.allclose(got, want, atol=1e-6)
        assert min(link_heights(geometry, arm, q)) >= MIN_LINK_Z_M


def test_a_motion_through_the_table_is_not_clear(geometry):
    home = np.asarray(geometry.robot.arms["left"].home, dtype=np.float64)
    down = home.copy()
    down[1] += 1.2  # the shoulder lowers the whole arm into the table
    assert min(link_heights(geometry, "left", down)) < 0.0
    assert not joint_path_clear(geometry, "left", home, down)
    assert joint_path_clear(geometry, "left", home, home)


def test_no_pose_is_kept_when_the_start_is_unreachable_back(geometry):
    home = np.asarray(geometry.robot.arms["left"].home, dtype=np.float64)
    buried = home.copy()
    buried[1] += 1.2  # a start below the table: no way out of it is clear
    assert calibration_plan(geometry, "left", buried, poses=12) == []
