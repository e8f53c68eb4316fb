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
