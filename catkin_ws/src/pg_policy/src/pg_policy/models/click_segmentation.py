"""The object under a clicked cell, as the learned click-conditioned segmenter sees it.

`ClickSegmentation(path)` loads a TorchScript pg_policy.models.nets.click_segmenter.ClickSegmenter;
`load_segmenter(spec)` the one a spec names: "shipped" (pg_policy/models/click-segmenter/click_segmenter.pt,
trained on simulated views of the training objects by `pushgrasp train-segmenter`), "none" or a model file.
`mask(hm, row, col)` runs the net on the window of WINDOW cells centred on the cell and keeps the cells it scores
at THRESHOLD or more that are valid and 8-connected to the clicked cell (or, when the click itself scores under it,
to the nearest such cell within SNAP_CELLS). The net sees colour, height and validity; its edges are blurred, so
the target loop uses it to group segments, not to draw them: `join_clicked` adds to a clicked object's mask the
segments (pg_policy.perception.segmentation) the net's mask covers for JOIN_SHARE of their cells (a mug's rim
and floor, a tool's handle and blade, a toy car's roof and body).

Frames and units: (H, W) grids of pg_core.heightmap (rows along y, columns along x); heights in metres.
Deterministic on CPU. Raised: FileNotFoundError for a missing model file, ValueError for a cell outside the grid.
"""

from __future__ import annotations

from functools import lru_cache
from pathlib import Path

import cv2
import numpy as np
import torch

from pg_core.heightmap import Heightmap
from pg_core.resources import shipped_models
from pg_policy.models.nets.click_segmenter import encode_window, paste_window

WINDOW = 128  # cells (a multiple of 32), the window the shipped net was trained on
THRESHOLD = 0.5  # a cell belongs to the object when the net's probability reaches this
SNAP_CELLS = 3  # a click the net leaves out snaps to its nearest object cell within this many cells
JOIN_SHARE = 0.8  # a segment is part of the clicked object when the net's mask covers this share of its cells
FILE = "click_segmenter.pt"


def shipped_path() -> Path:
    """The shipped model file (pg_policy/models/click-segmenter/click_segmenter.pt)."""
    return shipped_models() / "click-segmenter" / FILE


class ClickSegmentation:
    """The learned segmenter of one model file (module docstring)."""

    def __init__(self, path: str | Path) -> None:
        path = Path(path)
        if not path.is_file():
            raise FileNotFoundError(f"click segmenter model not found: {path}")
        self.path = path
        self.net = torch.jit.load(str(path), map_location="cpu").eval()

    def probability(self, hm: Heightmap, row: int, col: int) -> np.ndarray:
        """(H, W) float32 probability that each cell belongs to the object at (row, col) (0 outside the window)."""
        height = np.asarray(hm.height, np.float32)
        if not (0 <= row < height.shape[0] and 0 <= col < height.shape[1]):
            raise ValueError(f"cell (row {row}, col {col}) lies outside the {height.shape[0]} x {height.shape[1]} "
                             "heightmap")
        x = encode_window(np.asarray(hm.color), height, np.asarray(hm.valid, bool), row, col, WINDOW)
        with torch.no_grad():
            logits = self.net(torch.from_numpy(x)[None])[0, 0].numpy()
        return paste_window(1.0 / (1.0 + np.exp(-logits)), height.shape, row, col).astype(np.float32)

    def mask(self, hm: Heightmap, row: int, col: int) -> np.ndarray:
        """(H, W) bool: the object at (row, col) (module docstring); empty when the net finds none there."""
        keep = (self.probability(hm, row, col) >= THRESHOLD) & np.asarray(hm.valid, bool)
        _, parts = cv2.connectedComponents(keep.astype(np.uint8), connectivity=8)
        label = int(parts[row, col])
        if label == 0:
            k = SNAP_CELLS
            r0, c0 = max(row - k, 0), max(col - k, 0)
            near = np.argwhere(parts[r0:row + k + 1, c0:col + k + 1] > 0)
            if len(near) == 0:
                return np.zeros_like(keep)
            best = near[np.argmin(((near - [row - r0, col - c0]) ** 2).sum(axis=1))]
            label = int(parts[r0 + best[0], c0 + best[1]])
        return parts == label


    def join_clicked(self, hm: Heightmap, labels: np.ndarray, first: np.ndarray, row: int, col: int) -> np.ndarray:
        """(H, W) bool: the clicked object's mask `first` (from the segments `labels`, 0 none) joined with every
        other segment of `labels` that the net's mask of the click (row, col) covers JOIN_SHARE or more of: the
        parts of the clicked object that the segmentation split from it (a mug's rim and floor, a tool's handle
        and blade). The boundaries stay the segmentation's; the net only says which segments are one object."""
        net = self.mask(hm, row, col)
        out = np.asarray(first, bool).copy()
        labels = np.asarray(labels)
        for k in np.unique(labels[net & ~out]):
            seg = labels == k
            if k and int((net & seg).sum()) >= JOIN_SHARE * int(seg.sum()):
                out |= seg
        return out


SHIPPED, NONE = "shipped", "none"  # `load_segmenter` specs besides a model file's path
DEFAULT_SEGMENTER = NONE  # the target loop's default: the geometric segmentation alone (docs/RESULTS.md)


def load_segmenter(spec: str = DEFAULT_SEGMENTER) -> ClickSegmentation | None:
    """The segmenter a `spec` names: SHIPPED (the shipped model; None where none ships), NONE (None: the
    geometric segmentation alone) or the path of a TorchScript model file. Loaded once per spec. Raises
    FileNotFoundError for a path that is no file (naming the accepted specs)."""
    return _load(str(spec))


@lru_cache(maxsize=8)
def _load(spec: str) -> ClickSegmentation | None:
    if spec == NONE:
        return None
    if spec == SHIPPED:
        path = shipped_path()
        return ClickSegmentation(path) if path.is_file() else None
    if not Path(spec).is_file():
        raise FileNotFoundError(f"segmenter {spec!r}: no such model file (expected {SHIPPED!r}, {NONE!r} or the path "
                                "of a TorchScript click segmenter, e.g. runs/segmenter/click_segmenter.pt)")
    return ClickSegmentation(spec)
