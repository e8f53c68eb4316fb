"""Objects of different colour that one segment holds: split them apart (a step of
pg_policy.perception.segmentation.segment_objects).

A thin or small object lying against another (a rod along a bar, a small part on a larger object) has no seed of
its own in the watershed: its cells all lie within a cell of an edge, so the neighbour's seed floods it and the two
share one label, though a colour edge runs between them. `split_colours` looks inside every label for two groups of
chroma (CIE Lab a, b; lightness left out, as shading changes it) and splits off a connected piece of the second
group when
- the groups' median chromas lie COLOUR_EDGE or more apart (segmentation's colour edge),
- the piece holds at least `min_cells` cells, and so does the rest of the label,
- the piece meets the rest of the label at a colour edge: the median colour-edge strength (`edge_strength`'s
  colour part, 1.0 at the edge threshold) of its cells that touch the rest is at least 1. Shading that drifts
  across one object (a sphere's lit and dark halves) has no edge between its halves and stays whole.
The groups are the two sides of Otsu's threshold (OpenCV) on the chroma projected on its principal axis within the
label: deterministic, no random start.

Contract: labels (H, W) int32, 0 for no object and 1..N; chroma (H, W, 2) float32 Lab a, b; colour_edge (H, W)
float32 colour-edge strength. Returns (H, W) int32 labels, the pieces split off numbered after N (callers
renumber); the input is not changed.
"""

from __future__ import annotations

import cv2
import numpy as np

BORDER_EDGE = 1.0  # the median colour-edge strength of a piece's border with the rest must reach this


def _two_groups(chroma: np.ndarray) -> np.ndarray | None:
    """(n,) bool: the cells of the second chroma group of an (n, 2) float32 chroma list, or None when all alike."""
    centred = chroma - chroma.mean(axis=0)
    cov = centred.T @ centred / max(len(chroma) - 1, 1)
    _, vectors = np.linalg.eigh(cov)
    proj = centred @ vectors[:, -1]  # along the principal axis
    lo, hi = float(proj.min()), float(proj.max())
    if hi - lo < 1e-6:
        return None
    scaled = np.round((proj - lo) / (hi - lo) * 255).astype(np.uint8).reshape(-1, 1)
    _, split = cv2.threshold(scaled, 0, 1, cv2.THRESH_BINARY + cv2.THRESH_OTSU)
    return split.ravel().astype(bool)


def split_colours(labels: np.ndarray, chroma: np.ndarray, colour_edge: np.ndarray, edge: float,
                  min_cells: int) -> np.ndarray:
    """Labels with the pieces of another colour split off (module docstring); `edge`: the chroma distance that
    makes two colours differ (segmentation.COLOUR_EDGE); `min_cells`: the fewest cells of a piece and of the rest."""
    out = np.asarray(labels, np.int32).copy()
    next_label = int(out.max()) + 1
    grow = np.ones((3, 3), np.uint8)
    for label in range(1, int(labels.max()) + 1):
        seg = labels == label
        if seg.sum() < 2 * min_cells:
            continue
        second = _two_groups(chroma[seg].astype(np.float32))
        if second is None or min(second.sum(), (~second).sum()) < min_cells:
            continue
        cells = chroma[seg]
        if float(np.linalg.norm(np.median(cells[second], axis=0) - np.median(cells[~second], axis=0))) < edge:
            continue
        group = np.zeros_like(seg)
        group[seg] = second
        for side in (group, seg & ~group):  # either group may hold the piece of the other object
            count, parts = cv2.connectedComponents(side.astype(np.uint8), connectivity=8)
            for k in range(1, count):
                piece = parts == k
                rest = seg & ~piece & (out == label)
                if piece.sum() < min_cells or rest.sum() < min_cells:
                    continue
                border = piece & (cv2.dilate(rest.astype(np.uint8), grow) > 0)
                if not border.any() or float(np.median(colour_edge[border])) < BORDER_EDGE:
                    continue
                out[piece & (out == label)] = next_label
                next_label += 1
            if (out[seg] != label).any():
                break  # split once: the other side is what stays
    return out
