"""The ChArUco calibration board: its specification, its printable image and its detection (ROS-free, OpenCV).

Board frame (`board`): origin at the centre of the chessboard area, x along the columns (to the right in the
printed image), y along the rows (down in the printed image), z into the board (away from a viewer of the printed
face), as OpenCV's board frame shifted to the centre. Units: m in the board frame, px in images.

The default board (`DEFAULT_BOARD`): DICT_4X4_50, 5 x 4 squares of 30 mm, markers of 22 mm: a 150 x 120 mm
chessboard (170 x 140 mm with the 10 mm white quiet zone) that fits on a plate on a UR5e tool flange; at 0.7 m the
colour camera (fx = 615 px) sees a square as 26 px and a marker bit as 3.2 px, enough to detect it, and at the
0.3 - 0.45 m of the calibration poses as 41 - 62 px.

`python -m pg_policy.perception.charuco --out board.png [--dpi 300]` writes the image to print at 100 % scale.
"""

from __future__ import annotations

import argparse
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

MM_PER_INCH = 25.4


@dataclass(frozen=True)
class BoardSpec:
    """A ChArUco board: `squares` (columns, rows), square and marker sides (m), the ArUco dictionary's name
    (cv2.aruco.DICT_*) and the white quiet zone around the chessboard in the printed image (m)."""

    squares: tuple[int, int] = (5, 4)
    square_m: float = 0.030
    marker_m: float = 0.022
    dictionary: str = "DICT_4X4_50"
    margin_m: float = 0.010

    def __post_init__(self) -> None:
        if min(self.squares) < 2 or not 0.0 < self.marker_m < self.square_m or self.margin_m < 0.0:
            raise ValueError(f"ChArUco board {self}: needs >= 2 x 2 squares and 0 < marker_m < square_m")
        if not hasattr(cv2.aruco, self.dictionary):
            raise ValueError(f"unknown ArUco dictionary {self.dictionary!r} (a cv2.aruco.DICT_* name)")

    @property
    def size_m(self) -> tuple[float, float]:
        """(width, height) of the chessboard area (m), without the quiet zone."""
        return self.squares[0] * self.square_m, self.squares[1] * self.square_m

    @property
    def printed_size_m(self) -> tuple[float, float]:
        """(width, height) of the printed image (m): the chessboard and its quiet zone."""
        w, h = self.size_m
        return w + 2 * self.margin_m, h + 2 * self.margin_m

    def board(self) -> cv2.aruco.CharucoBoard:
        dictionary = cv2.aruco.getPredefinedDictionary(getattr(cv2.aruco, self.dictionary))
        return cv2.aruco.CharucoBoard(self.squares, self.square_m, self.marker_m, dictionary)

    def corners(self) -> np.ndarray:
        """(N, 3) float64 inner chessboard corners in the board frame (m), indexed by ChArUco corner id."""
        pts = np.asarray(self.board().getChessboardCorners(), dtype=np.float64).reshape(-1, 3)
        w, h = self.size_m
        return pts - np.array([w / 2, h / 2, 0.0])

    def image(self, px_per_m: float) -> np.ndarray:
        """The printable (H, W) uint8 image at `px_per_m` pixels per metre, quiet zone included; the chessboard
        area maps to board-frame x in [-w/2, w/2] left to right, y in [-h/2, h/2] top to bottom."""
        w, h = self.size_m
        margin = int(round(self.margin_m * px_per_m))
        inner = (int(round(w * px_per_m)), int(round(h * px_per_m)))
        img = self.board().generateImage(inner, marginSize=0, borderBits=1)
        return cv2.copyMakeBorder(img, margin, margin, margin, margin, cv2.BORDER_CONSTANT, value=255)


DEFAULT_BOARD = BoardSpec()


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
