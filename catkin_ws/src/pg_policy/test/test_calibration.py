"""pg_policy.perception.calibration: the shipped file equals the simulated camera; malformed files are clear errors."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from pg_core.geometry import load
from pg_core.resources import camera_calibration
from pg_policy.perception.calibration import CalibrationError, load_extrinsics

SHIPPED = camera_calibration()


def test_shipped_calibration_is_the_sim_camera():
    ext = load_extrinsics(SHIPPED)
    pose = load().camera.pose
    assert ext.parent == "world" and ext.child == "camera_color_optical_frame"
    assert np.allclose(ext.xyz, pose[:3, 3])
    assert np.allclose(Rotation.from_quat(ext.quaternion).as_matrix(), pose[:3, :3], atol=1e-9)


@pytest.mark.parametrize("text, match", [
    ("parent: world\nchild: cam\nrpy: [0, 0, 0]\n", "missing key 'xyz'"),
    ("parent: world\nchild: cam\nxyz: [0, 0]\nrpy: [0, 0, 0]\n", "3 finite numbers"),
    ("parent: world\nchild: cam\nxyz: [0, 0, 1]\n", "exactly one"),
    ("parent: world\nchild: cam\nxyz: [0, 0, 1]\nquaternion: [0, 0, 0, 2]\n", "norm"),
    ("child: cam\nxyz: [0, 0, 1]\nrpy: [0, 0, 0]\n", "'parent'"),
    ("[1, 2", "not valid YAML"),
])
def test_malformed_calibration(tmp_path, text, match):
    f = tmp_path / "cal.yaml"
    f.write_text(text)
    with pytest.raises(CalibrationError, match=match):
        load_extrinsics(f)
    with pytest.raises(CalibrationError, match="cannot read"):
        load_extrinsics(tmp_path / "missing.yaml")
