"""Eye-to-hand calibration of the fixed camera from a board on the tool (ROS-free; OpenCV, scipy).

Frames: `world` (the table surface, z up), `tool` (the flange frame whose pose forward kinematics gives, e.g.
`<arm>_tool0`), `board` (pg_policy.perception.charuco), the camera optical frame `camera_color_optical_frame`
(x right, y down, z forward). 4x4 transforms `a_b` map points of frame b into frame a (a <- b). Units: m, rad, px.

Unknowns: X = world <- camera and Y = tool <- board (the board's mount need not be known). Each view i gives the
tool pose T_i = world <- tool (forward kinematics) and the board's corners in the colour image. `solve`:
1. the board pose camera <- board of each view from its corners (solvePnP with the intrinsics K, no distortion:
   the RealSense colour stream is rectified);
2. X from cv2.calibrateHandEye in eye-to-hand form (the inverted tool poses: base <- tool becomes tool <- base,
   so its "camera to gripper" answer is camera to world), Y as the mean of T_i^-1 X (camera <- board)_i;
3. X and Y refined together by least squares (scipy, Huber loss of 1 px) on the reprojection error of every
   corner of every view: K (X^-1 T_i Y p) - pixel.
It reports the reprojection RMS (px) and the spread of the per-view camera poses T_i Y (camera <- board)_i^-1 about
X (RMS position mm, RMS angle deg), and refuses (`CalibrationFailed`) with fewer than `min_views` usable views.
`fit_depth` fits depth_true = scale * depth + offset against known planes: the table z = 0 seen from X, and
the board's face at X^-1 T_i Y in each view.
"""

from __future__ import annotations

import os
import tempfile
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np
from scipy.optimize import least_squares
from scipy.spatial.transform import Rotation

from pg_policy.perception.charuco import BoardSpec, Detection, board_pose

MIN_VIEWS = 6        # usable views (board found with >= MIN_CORNERS corners) needed for a solution
MIN_CORNERS = 6
CAMERA_FRAME = "camera_color_optical_frame"


class CalibrationFailed(ValueError):
    """The samples do not determine the camera pose (too few views of the board, a degenerate motion)."""


@dataclass(frozen=True)
class View:
    """One sample: `world_tool` 4x4 world <- tool from forward kinematics, and the board corners detected in the
    colour image taken there (and optionally the depth image)."""

    world_tool: np.ndarray
    detection: Detection
    depth: np.ndarray | None = None  # (H, W) m aligned with the colour image, 0 = no return; for fit_depth


@dataclass(frozen=True)
class HandEyeResult:
    world_camera: np.ndarray           # 4x4 world <- camera optical frame (refined)
    tool_board: np.ndarray             # 4x4 tool <- board (refined)
    initial_world_camera: np.ndarray   # cv2.calibrateHandEye's answer, before the refinement
    views: int                         # views used
    views_offered: int
    rms_px: float                      # reprojection RMS over every corner (px)
    view_rms_px: tuple[float, ...]     # per used view (px)
    position_spread_mm: float          # RMS distance of the per-view camera positions from X (mm)
    rotation_spread_deg: float         # RMS angle of the per-view camera rotations from X (deg)


def _matrix(rot: np.ndarray, t: np.ndarray) -> np.ndarray:
    m = np.eye(4)
    m[:3, :3] = rot
    m[:3, 3] = np.asarray(t, dtype=np.float64).reshape(3)
    return m


def _inv(t: np.ndarray) -> np.ndarray:
    return _matrix(t[:3, :3].T, -t[:3, :3].T @ t[:3, 3])


def _perturb(base: np.ndarray, x: np.ndarray) -> np.ndarray:
    """base times a small rigid motion x = (rotation vector rad, translation m), both in base's frame."""
    return base @ _matrix(Rotation.from_rotvec(x[:3]).as_matrix(), x[3:6])


def project(k: np.ndarray, camera_points: np.ndarray) -> np.ndarray:
    """(N, 2) pixels (u, v) of (N, 3) optical-frame points (pinhole K, pixel-centre convention)."""
    uv = camera_points[:, :2] / camera_points[:, 2:3]
    return uv * np.array([k[0, 0], k[1, 1]]) + np.array([k[0, 2], k[1, 2]])


def angle_deg(a: np.ndarray, b: np.ndarray) -> float:
    """The angle (deg) of the rotation between two 4x4 (or 3x3) transforms."""
    r = np.asarray(a)[:3, :3].T @ np.asarray(b)[:3, :3]
    return float(np.degrees(Rotation.from_matrix(r).magnitude()))


def solve(views: Sequence[View], spec: BoardSpec, k: np.ndarray, min_views: int = MIN_VIEWS,
          min_corners: int = MIN_CORNERS) -> HandEyeResult:
    """The camera pose in `world` (and the board on the tool) from views of the board (module docstring).
    Raises CalibrationFailed naming how many views showed the board when fewer than `min_views` did."""
    k = np.asarray(k, dtype=np.float64)
    corners = spec.corners()
    used: list[tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]] = []  # T_i, cam<-board, points, pixels
    for v in views:
        cam_board = board_pose(spec, v.detection, k, min_corners)
        if cam_board is not None:
            used.append((np.asarray(v.world_tool, dtype=np.float64), cam_board, corners[v.detection.ids],
                         v.detection.pixels))
    if len(used) < max(min_views, 3):
        raise CalibrationFailed(f"the board was seen (>= {min_corners} corners) in {len(used)} of {len(views)} "
                                f"poses; at least {max(min_views, 3)} are needed: nothing written")
    tool_base = [_inv(t) for t, _, _, _ in used]  # eye-to-hand: the inverted tool poses
    r_cam, t_cam = cv2.calibrateHandEye([m[:3, :3] for m in tool_base], [m[:3, 3] for m in tool_base],
                                        [c[:3, :3] for _, c, _, _ in used], [c[:3, 3] for _, c, _, _ in used],
                                        method=cv2.CALIB_HAND_EYE_PARK)
    x0 = _matrix(r_cam, t_cam)
    if not np.all(np.isfinite(x0)):
        raise CalibrationFailed("cv2.calibrateHandEye found no solution: the tool rotations vary too little")
    ys = [_inv(t) @ x0 @ c for t, c, _, _ in used]
    y0 = _matrix(Rotation.from_matrix([y[:3, :3] for y in ys]).mean().as_matrix(), np.mean([y[:3, 3] for y in ys], 0))

    def residuals(p: np.ndarray) -> np.ndarray:
        x_inv, y = _inv(_perturb(x0, p[:6])), _perturb(y0, p[6:])
        out = []
        for t, _, pts, px in used:
            m = x_inv @ t @ y
            cam = pts @ m[:3, :3].T + m[:3, 3]
            out.append((project(k, cam) - px).ravel())
        return np.concatenate(out)

    fit = least_squares(residuals, np.zeros(12), loss="huber", f_scale=1.0, x_scale=1e-2)
    x, y = _perturb(x0, fit.x[:6]), _perturb(y0, fit.x[6:])
    res = residuals(fit.x).reshape(-1, 2)
    sizes = np.cumsum([0] + [len(px) for _, _, _, px in used])
    view_rms = tuple(float(np.sqrt(np.mean(np.sum(res[a:b] ** 2, axis=1)))) for a, b in zip(sizes[:-1], sizes[1:],
                                                                                            strict=True))
    per_view = [t @ y @ _inv(c) for t, c, _, _ in used]
    pos = [float(np.linalg.norm(m[:3, 3] - x[:3, 3])) for m in per_view]
    ang = [angle_deg(m, x) for m in per_view]
    return HandEyeResult(
        world_camera=x, tool_board=y, initial_world_camera=x0, views=len(used), views_offered=len(views),
        rms_px=float(np.sqrt(np.mean(np.sum(res ** 2, axis=1)))), view_rms_px=view_rms,
        position_spread_mm=1e3 * float(np.sqrt(np.mean(np.square(pos)))),
        rotation_spread_deg=float(np.sqrt(np.mean(np.square(ang)))),
    )


@dataclass(frozen=True)
class DepthFit:
    """depth_true = scale * depth + offset (m) over `pixels` pixels of known planes; `rms_m` after the correction."""

    scale: float
    offset_m: float
    rms_m: float
    pixels: int


def plane_depth(k: np.ndarray, camera_plane: np.ndarray, shape: tuple[int, int]) -> np.ndarray:
    """(H, W) depth (m, along the optical axis) of the plane z = 0 of the frame `camera_plane` (4x4 camera <-
    plane); NaN where a pixel's ray does not meet it in front of the camera. The table: camera_plane = X^-1."""
    h, w = shape
    v, u = np.mgrid[0:h, 0:w]
    rays = np.stack([(u - k[0, 2]) / k[0, 0], (v - k[1, 2]) / k[1, 1], np.ones((h, w))], axis=-1)  # z = 1
    normal, point = camera_plane[:3, 2], camera_plane[:3, 3]
    with np.errstate(divide="ignore", invalid="ignore"):
        depth = float(normal @ point) / (rays @ normal)
    return np.where(depth > 0, depth, np.nan)


def board_depth(k: np.ndarray, camera_board: np.ndarray, spec: BoardSpec, shape: tuple[int, int],
                inset_m: float = 0.005) -> np.ndarray:
    """`plane_depth` of the board at `camera_board` (4x4 camera <- board), NaN outside its chessboard area shrunk
    by `inset_m` (m): the pixels where the camera sees the board's face."""
    w, h = (v / 2 - inset_m for v in spec.size_m)
    quad = np.array([[-w, -h, 0.0], [w, -h, 0.0], [w, h, 0.0], [-w, h, 0.0]]) @ camera_board[:3, :3].T
    px = project(k, quad + camera_board[:3, 3])
    mask = np.zeros(shape, dtype=np.uint8)
    cv2.fillConvexPoly(mask, np.round(px * 16).astype(np.int32), 1, shift=4)
    return np.where(mask > 0, plane_depth(k, camera_board, shape), np.nan)


def fit_depth(pairs: Sequence[tuple[np.ndarray, np.ndarray]], gate_m: float = 0.02,
              min_pixels: int = 1000) -> DepthFit:
    """Depth scale and offset: `pairs` of (measured (H, W) depth m, 0 = no return; predicted (H, W) depth m of a
    known plane, NaN elsewhere), e.g. the table (`plane_depth` of X^-1) and the board of each view
    (`board_depth`). Pixels within `gate_m` of the prediction (then within 3 RMS of the first fit) count. Both
    parameters need planes at several depths (the board at its poses and the table): from the table alone, seen
    nearly square on, only their combination at the table's depth is determined. Raises CalibrationFailed with
    fewer than `min_pixels` pixels."""
    meas = np.concatenate([np.asarray(m, dtype=np.float64).ravel() for m, _ in pairs])
    pred = np.concatenate([np.asarray(p, dtype=np.float64).ravel() for _, p in pairs])
    ok = np.isfinite(pred) & (meas > 0) & (np.abs(meas - pred) < gate_m)
    scale, offset, rms = 1.0, 0.0, float("nan")
    for _ in range(2):
        if int(ok.sum()) < min_pixels:
            raise CalibrationFailed(f"depth fit: {int(ok.sum())} pixels within {gate_m * 1e3:g} mm of the known "
                                    f"planes, {min_pixels} needed (are the table and the board in view?)")
        a = np.stack([meas[ok], np.ones(int(ok.sum()))], axis=1)
        (scale, offset), *_ = np.linalg.lstsq(a, pred[ok], rcond=None)
        err = scale * meas + offset - pred
        rms = float(np.sqrt(np.mean(err[ok] ** 2)))
        ok = ok & (np.abs(err) < max(3.0 * rms, 1e-4))
    return DepthFit(float(scale), float(offset), rms, int(ok.sum()))


def depth_pairs(result: HandEyeResult, views: Sequence[View], table: np.ndarray | None, k: np.ndarray,
                spec: BoardSpec) -> list[tuple[np.ndarray, np.ndarray]]:
    """The (measured, predicted) pairs of `fit_depth` from a solution: the table in `table` (a depth image with
    the table in view, or None) and the board in each view's depth image (views without one are skipped)."""
    x_inv = _inv(result.world_camera)
    pairs = []
    if table is not None:
        pairs.append((table, plane_depth(k, x_inv, table.shape)))
    for v in views:
        if v.depth is not None:
            pairs.append((v.depth, board_depth(k, x_inv @ v.world_tool @ result.tool_board, spec, v.depth.shape)))
    return pairs


def calibration_text(result: HandEyeResult, depth: DepthFit | None = None, parent: str = "world",
                     child: str = CAMERA_FRAME) -> str:
    """The calibration YAML that launch/robot.launch reads (pg_policy.perception.calibration: parent, child, xyz,
    quaternion), with the residuals under `hand_eye:` (ignored by the loader)."""
    x = result.world_camera
    q = Rotation.from_matrix(x[:3, :3]).as_quat()
    yb = result.tool_board
    lines = [
        f"# Camera extrinsics from a hand-eye calibration (pg_policy.perception.hand_eye): the pose of {child} in",
        f"# {parent}. Metres; rotation as a unit quaternion (x, y, z, w). Written by `pushgrasp calibrate` or",
        "# launch/calibrate.launch.",
        f"parent: {parent}",
        f"child: {child}",
        "xyz: [" + ", ".join(f"{v:.6f}" for v in x[:3, 3]) + "]",
        "quaternion: [" + ", ".join(f"{v:.8f}" for v in q) + "]",
        "hand_eye:",
        f"  views: {result.views}                 # of {result.views_offered} poses",
        f"  reprojection_rms_px: {result.rms_px:.4f}",
        f"  position_spread_mm: {result.position_spread_mm:.4f}",
        f"  rotation_spread_deg: {result.rotation_spread_deg:.5f}",
        "  tool_board_xyz: [" + ", ".join(f"{v:.6f}" for v in yb[:3, 3]) + "]",
        "  tool_board_quaternion: [" + ", ".join(f"{v:.8f}" for v in Rotation.from_matrix(yb[:3, :3]).as_quat()) + "]",
    ]
    if depth is not None:
        lines += [f"  depth_scale: {depth.scale:.6f}       # depth_true = scale * depth + offset",
                  f"  depth_offset_m: {depth.offset_m:.6f}",
                  f"  depth_rms_m: {depth.rms_m:.6f}",
                  f"  depth_pixels: {depth.pixels}"]
    return "\n".join(lines) + "\n"


def write_calibration(path: str | Path, result: HandEyeResult, depth: DepthFit | None = None) -> Path:
    """Write `calibration_text` to `path` atomically (a temporary file renamed over it); returns the path."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=path.name, suffix=".tmp", dir=path.parent)
    try:
        with os.fdopen(fd, "w", encoding="utf-8") as f:
            f.write(calibration_text(result, depth))
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    return path


def summary(result: HandEyeResult, depth: DepthFit | None = None) -> str:
    """One paragraph of the residuals, for a terminal or a log."""
    xyz = result.world_camera[:3, 3]
    rpy = Rotation.from_matrix(result.world_camera[:3, :3]).as_euler("xyz")
    text = (f"camera in world: xyz [{xyz[0]:.4f}, {xyz[1]:.4f}, {xyz[2]:.4f}] m, rpy [{rpy[0]:.4f}, {rpy[1]:.4f}, "
            f"{rpy[2]:.4f}] rad from {result.views} of {result.views_offered} poses; reprojection RMS "
            f"{result.rms_px:.3f} px (worst view {max(result.view_rms_px):.3f} px); per-view spread "
            f"{result.position_spread_mm:.2f} mm, {result.rotation_spread_deg:.3f} deg; OpenCV's start was "
            f"{1e3 * np.linalg.norm(result.initial_world_camera[:3, 3] - xyz):.2f} mm, "
            f"{angle_deg(result.initial_world_camera, result.world_camera):.3f} deg away")
    if depth is not None:
        text += (f"; depth = {depth.scale:.5f} x depth + {depth.offset_m * 1e3:.2f} mm (RMS {depth.rms_m * 1e3:.2f} "
                 f"mm over {depth.pixels} pixels of the table and the board)")
    return text
