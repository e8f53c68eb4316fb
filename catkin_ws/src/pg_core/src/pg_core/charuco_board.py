"""The ChArUco calibration board as printed: its specification and its image (OpenCV; no ROS, no detection).

One definition for everything that shows or detects the board: the printable PNG and the detection
(pg_policy.perception.charuco), the board on the simulated tool (pg_sim.world.calibration_board).

Board frame (`board`): origin at the centre of the chessboard area, x along the columns (to the right in the
printed image), y along the rows (down in the printed image), z into the board (away from a viewer of the printed
face), as OpenCV's board frame shifted to the centre. Units: m in the board frame, px in images.

The default board (`DEFAULT_BOARD`): DICT_4X4_50, 5 x 4 squares of 30 mm, markers of 22 mm: a 150 x 120 mm
chessboard (170 x 140 mm with the 10 mm white quiet zone) that fits on a plate on a UR5e tool flange; at 0.7 m the
colour camera (fx = 615 px) sees a square as 26 px and a marker bit as 3.2 px, enough to detect it, and at the
0.3 - 0.45 m of the calibration poses as 41 - 62 px.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np


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
