"""The ChArUco calibration board's detection and printable PNG (ROS-free, OpenCV). The board itself (its frame,
its specification `BoardSpec` and the default `DEFAULT_BOARD`) is pg_core.charuco_board's.

`python -m pg_policy.perception.charuco --out board.png [--dpi 300]` writes the image to print at 100 % scale.
"""

from __future__ import annotations

import argparse
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

from pg_core.charuco_board import DEFAULT_BOARD, BoardSpec

__all__ = ["DEFAULT_BOARD", "BoardSpec", "Detection", "board_pose", "describe", "detect", "write_image"]

MM_PER_INCH = 25.4




@dataclass(frozen=True)
class Detection:
    """ChArUco corners found in one image: `ids` (N,) int corner ids, `pixels` (N, 2) float64 (u, v) px."""

    ids: np.ndarray
    pixels: np.ndarray


def detect(spec: BoardSpec, image: np.ndarray) -> Detection:
    """The board's corners in an RGB (H, W, 3) or grey (H, W) uint8 image, sub-pixel refined; an empty Detection
    when the board is not found."""
    grey = image if image.ndim == 2 else cv2.cvtColor(image, cv2.COLOR_RGB2GRAY)
    params = cv2.aruco.CharucoParameters()
    detector_params = cv2.aruco.DetectorParameters()
    detector_params.cornerRefinementMethod = cv2.aruco.CORNER_REFINE_SUBPIX
    detector = cv2.aruco.CharucoDetector(spec.board(), params, detector_params)
    corners, ids, _, _ = detector.detectBoard(grey)
    if ids is None or len(ids) == 0:
        return Detection(np.zeros(0, dtype=np.int64), np.zeros((0, 2)))
    pts = np.asarray(corners, dtype=np.float32).reshape(-1, 1, 2)
    # window about a third of the pixel distance between neighbouring corners, at least 2 px
    span = _corner_spacing_px(pts.reshape(-1, 2))
    win = int(np.clip(span / 3.0, 2, 8))
    criteria = (cv2.TERM_CRITERIA_EPS + cv2.TERM_CRITERIA_MAX_ITER, 50, 1e-3)
    refined = cv2.cornerSubPix(grey, pts.copy(), (win, win), (-1, -1), criteria)
    return Detection(np.asarray(ids, dtype=np.int64).reshape(-1), refined.reshape(-1, 2).astype(np.float64))


def _corner_spacing_px(pixels: np.ndarray) -> float:
    """The median distance (px) from each corner to its nearest other corner (inf for one corner)."""
    if len(pixels) < 2:
        return float("inf")
    d = np.linalg.norm(pixels[:, None, :] - pixels[None, :, :], axis=-1)
    np.fill_diagonal(d, np.inf)
    return float(np.median(d.min(axis=1)))


def board_pose(spec: BoardSpec, det: Detection, k: np.ndarray, min_corners: int = 6) -> np.ndarray | None:
    """4x4 camera optical frame <- board from a detection (solvePnP, no distortion); None with fewer than
    `min_corners` corners."""
    if len(det.ids) < min_corners:
        return None
    obj = spec.corners()[det.ids]
    ok, rvec, tvec = cv2.solvePnP(obj, det.pixels, np.asarray(k, dtype=np.float64), None,
                                  flags=cv2.SOLVEPNP_IPPE)
    if not ok:
        return None
    rvec, tvec = cv2.solvePnPRefineLM(obj, det.pixels, np.asarray(k, dtype=np.float64), None, rvec, tvec)
    t = np.eye(4)
    t[:3, :3] = cv2.Rodrigues(rvec)[0]
    t[:3, 3] = tvec.reshape(3)
    return t


def write_image(path: str | Path, spec: BoardSpec = DEFAULT_BOARD, dpi: float = 300.0) -> tuple[int, int]:
    """Write the printable PNG at `dpi` (stored in the PNG where Pillow is installed); returns its (width, height)
    px. Raises ValueError when the file cannot be written."""
    img = spec.image(dpi / MM_PER_INCH * 1000.0)
    try:
        from PIL import Image
    except ImportError:
        Image = None  # noqa: N806
    try:
        if Image is not None:
            Image.fromarray(img).save(str(path), format="PNG", dpi=(dpi, dpi))
        elif not cv2.imwrite(str(path), img):
            raise OSError("cv2.imwrite failed")
    except OSError as exc:
        raise ValueError(f"cannot write the board image {path}: {exc}") from None
    return img.shape[1], img.shape[0]


def describe(spec: BoardSpec = DEFAULT_BOARD) -> str:
    w, h = spec.printed_size_m
    return (f"ChArUco {spec.dictionary}, {spec.squares[0]} x {spec.squares[1]} squares of {spec.square_m * 1e3:g} mm, "
            f"markers {spec.marker_m * 1e3:g} mm; print at 100 % scale: {w * 1e3:g} x {h * 1e3:g} mm "
            f"(chessboard {spec.size_m[0] * 1e3:g} x {spec.size_m[1] * 1e3:g} mm)")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description="Write the ChArUco calibration board as a PNG to print at 100 %.")
    parser.add_argument("--out", required=True, help="PNG file to write")
    parser.add_argument("--dpi", type=float, default=300.0, help="print resolution (default 300)")
    args = parser.parse_args(argv)
    w, h = write_image(args.out, DEFAULT_BOARD, args.dpi)
    print(f"{args.out}: {w} x {h} px at {args.dpi:g} dpi; {describe(DEFAULT_BOARD)}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
