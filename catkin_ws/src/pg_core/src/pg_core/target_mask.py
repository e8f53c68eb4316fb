"""Goal masks: the heightmap cells showing an object of a named palette colour (HSV thresholds, OpenCV).

Colours are compared in OpenCV's 8-bit ``HSV_FULL`` space: hue H in 0-255 for a full turn (1 unit = 1.41 deg,
circular), saturation S and value V in 0-255. A uniform shading factor k (the simulator's ambient 0.65 + diffuse 0.4
lighting, or a dimmer real scene) scales R, G and B alike, which leaves H and S unchanged and scales V, so every
palette colour gets a window on H and S and only a lower bound on V:

- chromatic colours (palette S >= ``ACHROMATIC_SAT``): |H - H_c| < ``HUE_TOL`` and S within ``SAT_TOL`` x S_c of S_c;
- achromatic colours (gray, white): any H, S in [0, ``ACHROMATIC_SAT``);
- V >= max(``VALUE_FLOOR``, ``VALUE_MIN_FRACTION`` x V_c) (the simulator never shades below 0.65 x V_c).

Where two windows (of palette colours or of ``palette.BACKGROUND``, e.g. the table) overlap, each is cut at the
midpoint between the two colours along the axis that separates them better (hue or saturation, relative to the
window sizes), so no cell can belong to two palette colours and the table never counts as a target.
``WINDOWS`` holds the result for every ``PALETTE`` name. Matching regions of fewer than ``MIN_BLOB_CELLS`` cells are
then dropped as speckle (an optional morphological opening is available but off: it erases thin slivers).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import cv2
import numpy as np

from pg_core.palette import BACKGROUND, PALETTE, RGB, normalize_name, shown_name

HUE_TOL = 10.0  # largest hue half-width (HSV_FULL units; 10 = 14.1 deg)
SAT_TOL = 0.4  # largest relative saturation deviation from the palette colour
ACHROMATIC_SAT = 40.0  # palette colours less saturated than this are matched on saturation only
VALUE_MIN_FRACTION = 0.5  # cells darker than this fraction of the palette V are rejected
VALUE_FLOOR = 40.0  # below this V, hue and saturation are unreliable
MIN_BLOB_CELLS = 5  # matching regions smaller than this (cells) are dropped as speckle
MIN_VISIBLE_CELLS = 25  # the target counts as visible from 25 cells = 1 cm^2 at 0.002 m resolution


class TargetNotVisible(ValueError):
    """The target mask holds too few cells to act on (target hidden, removed, or not in the workspace)."""


@dataclass(frozen=True)
class HsvWindow:
    """Accepted HSV_FULL region of one colour.

    A cell matches when |H - hue| < hue_half (circular; hue None: any hue), sat_lo <= S < sat_hi and V >= val_lo.
    """

    name: str
    hue: float | None
    hue_half: float
    sat_lo: float
    sat_hi: float
    val_lo: float
    sat: float  # the palette colour's own S (the separation midpoints are taken between these)

    def contains(self, hsv: np.ndarray) -> np.ndarray:
        """(H, W) bool: which cells of an (H, W, 3) uint8 HSV_FULL image fall in the window."""
        h, s, v = (hsv[..., i].astype(np.float32) for i in range(3))
        ok = (s >= self.sat_lo) & (s < self.sat_hi) & (v >= self.val_lo)
        if self.hue is not None:
            ok &= _hue_gap(h, self.hue) < self.hue_half
        return ok


def _hue_gap(a: np.ndarray | float, b: float) -> np.ndarray | float:
    """Circular distance between hues in HSV_FULL units (0..128)."""
    d = np.abs(np.asarray(a, dtype=np.float32) - np.float32(b)) % 256.0
    return np.minimum(d, 256.0 - d)


def rgb_to_hsv(rgb: RGB) -> tuple[float, float, float]:
    """One RGB triple (0-255) -> (H, S, V) in OpenCV HSV_FULL units."""
    h, s, v = cv2.cvtColor(np.uint8([[rgb]]), cv2.COLOR_RGB2HSV_FULL)[0, 0]
    return float(h), float(s), float(v)


def _initial(name: str, rgb: RGB) -> HsvWindow:
    h, s, v = rgb_to_hsv(rgb)
    val_lo = max(VALUE_FLOOR, VALUE_MIN_FRACTION * v)
    if s < ACHROMATIC_SAT:
        return HsvWindow(name, None, 128.0, 0.0, ACHROMATIC_SAT, val_lo, s)
    return HsvWindow(name, h, HUE_TOL, s * (1 - SAT_TOL), min(256.0, s * (1 + SAT_TOL)), val_lo, s)


def _separate(a: HsvWindow, b: HsvWindow) -> HsvWindow:
    """Window `a` cut so that it no longer overlaps `b` (both as first built); unchanged when they do not overlap."""
    if a.sat_hi <= b.sat_lo or b.sat_hi <= a.sat_lo:
        return a
    sat_scale = (a.sat_hi - a.sat_lo + b.sat_hi - b.sat_lo) / 2
    sat_margin = abs(a.sat - b.sat) / sat_scale
    hue_margin = -1.0
    if a.hue is not None and b.hue is not None:
        gap = float(_hue_gap(a.hue, b.hue))
        if gap >= a.hue_half + b.hue_half:
            return a
        hue_margin = gap / (a.hue_half + b.hue_half)
    if hue_margin > sat_margin:
        return replace(a, hue_half=min(a.hue_half, float(_hue_gap(a.hue, b.hue)) / 2))
    mid = (a.sat + b.sat) / 2
    return replace(a, sat_hi=min(a.sat_hi, mid)) if a.sat < b.sat else replace(a, sat_lo=max(a.sat_lo, mid))


def _build_windows() -> dict[str, HsvWindow]:
    first = {n: _initial(n, rgb) for n, rgb in {**PALETTE, **BACKGROUND}.items()}
    out = {}
    for name in PALETTE:
        w = first[name]
        for other, ow in first.items():
            if other != name:
                cut = _separate(first[name], ow)
                w = replace(w, hue_half=min(w.hue_half, cut.hue_half), sat_lo=max(w.sat_lo, cut.sat_lo),
                            sat_hi=min(w.sat_hi, cut.sat_hi))
        out[name] = w
    return out


WINDOWS: dict[str, HsvWindow] = _build_windows()


def hsv_window(name: str) -> HsvWindow:
    """The window of a palette colour name (case-insensitive, ``grey`` accepted); ValueError listing known names."""
    key = normalize_name(name)
    if key not in WINDOWS:
        raise ValueError(f"unknown target colour {shown_name(name)}; known colours: {', '.join(sorted(WINDOWS))}")
    return WINDOWS[key]


def target_mask(color: np.ndarray, valid: np.ndarray, name: str, min_blob_cells: int = MIN_BLOB_CELLS,
                open_size: int = 0) -> np.ndarray:
    """(H, W) bool mask of the cells whose colour matches palette colour `name`.

    color: (H, W, 3) uint8 RGB colour heightmap; valid: (H, W) bool validity mask (invalid cells never match);
    min_blob_cells: 8-connected matching regions smaller than this many cells are dropped (speckle), 0 = keep all;
    open_size: side (cells) of a square morphological opening applied first, 0 or 1 = none (off by default: it
    erases the thin visible slivers of a partly buried target).
    Raises ValueError for an unknown colour name (listing the known ones) or mismatched/ill-typed arrays.
    """
    window = hsv_window(name)
    color = np.asarray(color)
    valid = np.asarray(valid)
    if color.ndim != 3 or color.shape[2] != 3 or color.dtype != np.uint8:
        raise ValueError(f"color must be an (H, W, 3) uint8 RGB image, got {color.shape} {color.dtype}")
    if valid.shape != color.shape[:2]:
        raise ValueError(f"valid mask shape {valid.shape} does not match color {color.shape[:2]}")
    hsv = cv2.cvtColor(np.ascontiguousarray(color), cv2.COLOR_RGB2HSV_FULL)
    mask = window.contains(hsv) & valid.astype(bool)
    if open_size > 1:
        kernel = np.ones((open_size, open_size), np.uint8)
        mask = cv2.morphologyEx(mask.astype(np.uint8), cv2.MORPH_OPEN, kernel).astype(bool)
    if min_blob_cells > 1 and mask.any():
        count, labels, stats, _ = cv2.connectedComponentsWithStats(mask.astype(np.uint8), connectivity=8)
        keep = stats[:, cv2.CC_STAT_AREA] >= min_blob_cells
        keep[0] = False  # background label
        mask = keep[labels]
    return mask


def disc_kernel(radius_cells: int) -> np.ndarray:
    """(2k+1, 2k+1) uint8 structuring element of the cells within `radius_cells` (Euclidean) of the centre."""
    k = max(int(radius_cells), 0)
    i, j = np.mgrid[-k : k + 1, -k : k + 1]
    return (i * i + j * j <= k * k).astype(np.uint8)


def radius_cells(radius_m: float, resolution: float) -> int:
    """A metric radius (m) as a whole number of heightmap cells (resolution in m/cell), rounded; ValueError if < 0."""
    if radius_m < 0 or resolution <= 0:
        raise ValueError(f"radius must be >= 0 m and resolution > 0 m/cell, got {radius_m}, {resolution}")
    return int(round(radius_m / resolution))


def dilate_mask(mask: np.ndarray, resolution: float, radius_m: float) -> np.ndarray:
    """(H, W) bool: `mask` grown by a disc of `radius_m` metres (cells at most round(radius_m / resolution) away)."""
    k = radius_cells(radius_m, resolution)
    m = np.asarray(mask, dtype=bool)
    if k == 0 or not m.any():
        return m.copy()
    return cv2.dilate(m.astype(np.uint8), disc_kernel(k), borderType=cv2.BORDER_CONSTANT, borderValue=0).astype(bool)
