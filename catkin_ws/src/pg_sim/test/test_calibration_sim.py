"""The camera calibration in simulation (pg_learning.cli.calibrate.simulate over pg_sim.world.calibration_board and
pg_policy.perception.hand_eye): a camera moved 2 cm and 2 deg from its configured pose, in a random direction of the
seed, is found within 2 mm and 0.2 deg from 12 rendered views of the board; a few seconds per run."""

from __future__ import annotations

import numpy as np
import pytest

from pg_learning.cli import calibrate
from pg_policy.perception.hand_eye import CalibrationFailed, angle_deg


@pytest.mark.parametrize("seed", [0, 7])
def test_a_perturbed_camera_is_recovered_within_2_mm_and_0_2_deg(seed):
    run = calibrate.simulate(pose_error_mm=20.0, pose_error_deg=2.0, seed=seed, poses=12)
    assert np.linalg.norm(run.configured[:3, 3] - run.true_pose[:3, 3]) == pytest.approx(0.02, abs=1e-9)
    assert angle_deg(run.configured, run.true_pose) == pytest.approx(2.0, abs=1e-6)
    pos_mm, rot_deg = run.errors
    assert pos_mm < 2.0 and rot_deg < 0.2, (pos_mm, rot_deg)
    assert run.result.views == 12 and run.result.rms_px < 0.5
    # the perfect depth needs no correction
    assert run.depth.scale == pytest.approx(1.0, abs=2e-3) and abs(run.depth.offset_m) < 1e-3


def test_too_few_poses_write_nothing_and_say_how_many(tmp_path):
    with pytest.raises(CalibrationFailed, match="in 4 of 4 poses"):
        calibrate.simulate(seed=1, poses=4)
    out = tmp_path / "camera_calibration.yaml"
    assert calibrate.main(["--sim", "--poses", "4", "--out", str(out)]) == 1 and not out.exists()


def test_a_board_attached_to_the_world_follows_the_arm_into_every_capture():
    """World.attach_board (the sim node's ~calibration_board): the board shows where the arm holds it."""
    from pg_core.calibration_poses import calibration_plan
    from pg_policy.perception.charuco import DEFAULT_BOARD, detect
    from pg_sim.world.world import World

    with World() as world:
        with pytest.raises(ValueError, match="unknown arm 'middle'"):
            world.attach_board("middle")
        world.attach_board("left")
        with pytest.raises(ValueError, match="mounted on the left arm already"):
            world.attach_board("right")
        assert len(detect(DEFAULT_BOARD, world.capture().color).ids) == 0  # at home the board is out of view
        home = np.asarray(world.geometry.robot.arms["left"].home)
        q = calibration_plan(world.geometry, "left", home, poses=12)[0]
        world.arms["left"].reset(q, world.geometry.gripper.max_opening)
        assert len(detect(DEFAULT_BOARD, world.capture().color).ids) >= 6
        world.detach_board()
        assert world.board is None and len(detect(DEFAULT_BOARD, world.capture().color).ids) == 0
