"""pg_policy.perception.hand_eye and .charuco on synthetic views: a known camera and board mount, the board's corners
projected with pixel noise; the solver recovers the camera pose, refuses too few views, and fits depth."""

from __future__ import annotations

import cv2
import numpy as np
import pytest
import yaml
from scipy.spatial.transform import Rotation

from pg_policy.perception.calibration import load_extrinsics
from pg_policy.perception.charuco import DEFAULT_BOARD, Detection, detect
from pg_policy.perception.hand_eye import (
    CalibrationFailed,
    View,
    angle_deg,
    depth_pairs,
    fit_depth,
    plane_depth,
    project,
    solve,
    write_calibration,
)

K = np.array([[615.0, 0.0, 319.5], [0.0, 615.0, 239.5], [0.0, 0.0, 1.0]])
SHAPE = (480, 640)


def _pose(rotvec: np.ndarray | list[float], xyz: np.ndarray | list[float]) -> np.ndarray:
    t = np.eye(4)
    t[:3, :3] = Rotation.from_rotvec(rotvec).as_matrix()
    t[:3, 3] = xyz
    return t


# a camera 0.7 m above the table looking down, moved off its nominal pose; the board 16 cm beyond the flange
CAMERA = _pose([np.pi, 0.0, 0.0], [0.0, 0.0, 0.70]) @ _pose([0.02, -0.03, 0.01], [0.012, -0.015, 0.008])
MOUNT = _pose([np.pi, 0.0, 0.0], [0.0, 0.0, 0.16]) @ _pose([0.0, 0.0, 0.3], [0.004, -0.002, 0.0])


def _views(n: int, noise_px: float, rng: np.random.Generator) -> list[View]:
    """Board facing up at z 0.36-0.44 m with tilts up to 25 deg and yaws up to 40 deg; corners projected, noisy."""
    views = []
    corners = DEFAULT_BOARD.corners()
    for _ in range(n):
        board = _pose([np.pi, 0.0, 0.0], [0, 0, 0])
        board[:3, :3] = (Rotation.from_rotvec(np.r_[rng.uniform(-1, 1, 2) * np.radians(18), 0.0])
                         * Rotation.from_euler("z", rng.uniform(-0.7, 0.7))).as_matrix() @ board[:3, :3]
        board[:3, 3] = [rng.uniform(-0.05, 0.05), rng.uniform(-0.05, 0.05), rng.uniform(0.36, 0.44)]
        world_tool = board @ np.linalg.inv(MOUNT)
        cam_board = np.linalg.inv(CAMERA) @ board
        px = project(K, corners @ cam_board[:3, :3].T + cam_board[:3, 3]) + rng.normal(0, noise_px, (len(corners), 2))
        views.append(View(world_tool, Detection(np.arange(len(corners)), px)))
    return views


def test_the_solver_recovers_the_camera_from_noisy_corners():
    rng = np.random.default_rng(3)
    result = solve(_views(12, 0.2, rng), DEFAULT_BOARD, K)
    assert np.linalg.norm(result.world_camera[:3, 3] - CAMERA[:3, 3]) < 1e-3
    assert angle_deg(result.world_camera, CAMERA) < 0.05
    assert np.linalg.norm(result.tool_board[:3, 3] - MOUNT[:3, 3]) < 1e-3
    assert 0.1 < result.rms_px < 0.35 and result.views == 12


def test_the_solver_refuses_too_few_views_and_says_how_many_it_saw():
    rng = np.random.default_rng(4)
    views = _views(8, 0.2, rng)
    blind = [View(v.world_tool, Detection(np.zeros(0, dtype=np.int64), np.zeros((0, 2)))) for v in views[:4]]
    with pytest.raises(CalibrationFailed, match="seen .* in 4 of 8 poses"):
        solve(views[4:] + blind, DEFAULT_BOARD, K)


def test_the_calibration_file_is_what_robot_launch_reads(tmp_path):
    result = solve(_views(10, 0.1, np.random.default_rng(5)), DEFAULT_BOARD, K)
    path = write_calibration(tmp_path / "camera_calibration.yaml", result)
    ext = load_extrinsics(path)
    assert (ext.parent, ext.child) == ("world", "camera_color_optical_frame")
    assert np.allclose(ext.xyz, result.world_camera[:3, 3], atol=1e-6)
    q = Rotation.from_quat(ext.quaternion).as_matrix()
    assert np.allclose(q, result.world_camera[:3, :3], atol=1e-6)
    assert yaml.safe_load(path.read_text())["hand_eye"]["views"] == 10


def test_the_depth_fit_finds_scale_and_offset_from_the_table_and_the_board():
    rng = np.random.default_rng(6)
    views = _views(6, 0.1, rng)
    result = solve(views, DEFAULT_BOARD, K)

    def sensed(true: np.ndarray) -> np.ndarray:  # a sensor reading (true - 0.004) / 1.02, and no return where NaN
        return np.nan_to_num((true - 0.004) / 1.02 + rng.normal(0, 5e-4, true.shape), nan=0.0)

    table = sensed(plane_depth(K, np.linalg.inv(CAMERA), SHAPE))
    boards = [View(v.world_tool, v.detection, sensed(plane_depth(K, np.linalg.inv(CAMERA) @ v.world_tool @ MOUNT,
                                                                   SHAPE))) for v in views]
    fit = fit_depth(depth_pairs(result, boards, table, K, DEFAULT_BOARD))
    assert fit.scale == pytest.approx(1.02, abs=0.005) and fit.offset_m == pytest.approx(0.004, abs=0.002)
    with pytest.raises(CalibrationFailed, match="pixels within"):
        fit_depth([(np.zeros(SHAPE), plane_depth(K, np.linalg.inv(CAMERA), SHAPE))])


def test_the_printed_board_is_detected_at_every_corner():
    img = DEFAULT_BOARD.image(4000.0)
    det = detect(DEFAULT_BOARD, img)
    assert sorted(det.ids.tolist()) == list(range(12))
    # corner pixels agree with the board frame: x = (u + 0.5) / ppm - printed width / 2 (pixel-centre convention)
    w, h = DEFAULT_BOARD.printed_size_m
    board_xy = (det.pixels + 0.5) / 4000.0 - np.array([w / 2, h / 2])
    assert np.abs(board_xy - DEFAULT_BOARD.corners()[det.ids, :2]).max() < 2e-5


def _warped(cam_board: np.ndarray, ppm: float = 4000.0) -> np.ndarray:
    """A grey (480, 640) image of the printed board at `cam_board` (4x4 camera <- board): the print warped by the
    homography of its plane, on a mid-grey background."""
    img = DEFAULT_BOARD.image(ppm)
    w, h = DEFAULT_BOARD.printed_size_m
    to_board = np.array([[1 / ppm, 0, 0.5 / ppm - w / 2], [0, 1 / ppm, 0.5 / ppm - h / 2], [0, 0, 1]])  # print px
    hom = K @ np.column_stack([cam_board[:3, 0], cam_board[:3, 1], cam_board[:3, 3]]) @ to_board
    out = cv2.warpPerspective(img, hom, (SHAPE[1], SHAPE[0]), flags=cv2.INTER_AREA, borderValue=128)
    return out


def test_the_node_session_detects_warped_boards_and_writes_the_file(tmp_path):
    from pg_policy.ros.hand_eye_node import HandEyeSession

    rng = np.random.default_rng(8)
    session = HandEyeSession(K)
    for v in _views(8, 0.0, rng):
        cam_board = np.linalg.inv(CAMERA) @ v.world_tool @ MOUNT
        assert session.add(v.world_tool, cv2.cvtColor(_warped(cam_board), cv2.COLOR_GRAY2RGB), None) >= 8
    text = session.solve(str(tmp_path / "cal.yaml"))
    ext = load_extrinsics(tmp_path / "cal.yaml")
    assert "wrote" in text and np.linalg.norm(np.subtract(ext.xyz, CAMERA[:3, 3])) < 2e-3
    assert angle_deg(Rotation.from_quat(ext.quaternion).as_matrix(), CAMERA[:3, :3]) < 0.2
    empty = HandEyeSession(K)
    assert empty.add(np.eye(4), np.full((480, 640, 3), 128, np.uint8), None) == 0
    with pytest.raises(CalibrationFailed, match="in 0 of 1 poses"):
        empty.solve(str(tmp_path / "none.yaml"))
    assert not (tmp_path / "none.yaml").exists()


def test_the_node_decodes_camera_images():
    from sensor_msgs.msg import Image

    from pg_policy.ros.hand_eye_node import image_array

    rgb = np.arange(2 * 3 * 3, dtype=np.uint8).reshape(2, 3, 3)
    msg = Image(height=2, width=3, encoding="bgr8", step=9, data=rgb[:, :, ::-1].tobytes())
    assert np.array_equal(image_array(msg), rgb)
    mm = np.array([[700, 0], [701, 5]], dtype=np.uint16)
    depth = image_array(Image(height=2, width=2, encoding="16UC1", step=4, data=mm.tobytes()))
    assert depth.dtype == np.float32 and np.allclose(depth, mm / 1000.0)
    with pytest.raises(ValueError, match="encoding"):
        image_array(Image(height=1, width=1, encoding="mono16", step=2, data=b"\0\0"))
