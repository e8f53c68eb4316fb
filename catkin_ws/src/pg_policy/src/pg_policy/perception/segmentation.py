"""Object segmentation of a top-down heightmap without a colour palette: which cells belong to which object.

Contract. Input: a pg_core.heightmap.Heightmap in `world` ((H, W) cells, rows along y, columns along x; height in
metres above the workspace zmin; colour (H, W, 3) uint8 RGB; valid (H, W) bool). Object cells are valid cells higher
than SEGMENT_HEIGHT_M (4 mm, half of pg_core.heightmap.OBJECT_HEIGHT_M: a fork, knife or pair of scissors lying
flat stands 4-7 mm), and valid cells higher than THIN_HEIGHT_M (2 mm) whose colour stands out from the table's (a
card or a thin slab lying flat; `object_cells`); every other cell is table (or unseen) and carries label 0.

Method (OpenCV and scipy.ndimage):
1. edges: a cell lies on an edge when, within its 3 x 3 neighbourhood, the height bends by at least DEPTH_EDGE_M
   (|h(p + d) + h(p - d) - 2 h(p)| along a row, column or diagonal: the height of a step between objects, or an
   object and the table, while any plane, however steep, bends by nothing: a tilted or curved top is no edge) or
   the colour spans at least COLOUR_EDGE (the CIE Lab distance between the extreme neighbours, chroma weighted above
   lightness so that shading on a curved top is no edge); invalid cells count as edges too (the unseen side of an
   object is where two objects meet);
2. seeds: the object cells off every edge, shrunk by SEED_ERODE_CELLS, split into 8-connected components; components
   smaller than MIN_SEED_CELLS are dropped (slivers between edges);
3. watershed (scipy.ndimage.watershed_ift) of the edge strength from those seeds, the table being one more seed, so
   every object cell joins the seed it reaches over the lowest edges; two touching objects of different height or
   colour stay apart, while one object of uniform height and colour is one seed and one label;
4. object cells the table basin reaches first (rims, pieces too thin for a seed) join the nearest label when they
   touch one, else form a label of their own;
5. cells a single label encloses (a bowl's or cup's floor, lower than SEGMENT_HEIGHT_M or unseen) join it, and so
   does a raised floor of its colour that it encloses (pg_policy.perception.floors), and a raised hub of its
   colour on a body of it that falls away from the hub (pg_policy.perception.hubs); labels
   under MIN_OBJECT_CELLS cells are dropped to 0; a label holding a connected piece of another chroma (COLOUR_EDGE
   apart, at least MIN_OBJECT_CELLS cells, meeting the rest at a colour edge) is split there
   (pg_policy.perception.colour_pieces: a rod or a small part too thin for a seed of its own, flooded from the
   neighbour it lies against);
6. pieces of one long object join (pg_policy.perception.long_pieces): a label at least as elongated as
   JOIN_ELONGATION (the minor /
   major spread of its cells) takes in a label of its colour (median weighted Lab within COLOUR_EDGE) and height
   (medians within JOIN_HEIGHT_M) that continues it along its major axis (the other's cells lie, at the median,
   within its half-width plus JOIN_OFFSET_CELLS of the axis and, at the 95th percentile, within twice that; a
   label not round itself is aligned within JOIN_ANGLE_DEG), either end to end (touching, their extents along the
   axis overlapping by at most the half-width, both elongated: a bar bent over something, a rod tilted where it
   leaves the table) or beyond a gap of at most JOIN_GAP_M whose band of the piece's width is at least
   JOIN_COVERED unseen or other objects' cells no lower than the pieces (a rod seen on both sides of an object
   lying across it). Joined labels need not be connected.

A click on a part that no seed of its own holds (a sliver of an object mostly under a neighbour: fewer seed cells
than MIN_SEED_CELLS) lands in the neighbour's label. `segment_at` therefore looks at the clicked cell's own piece:
the label's cells within COLOUR_EDGE of the chroma (Lab a, b) around the click, 8-connected to it. When the rest
of the label differs from that piece in median chroma by at least COLOUR_EDGE, the clicked object is the piece,
not the label; the same holds for a click on the object on top, whose label took the sliver in. Lightness is left
out (shading on one object changes it), so objects told apart by lightness alone stay merged, and a click on a
printed part of a real object names that part. Where chroma tells nothing (a sliver under a look-alike of its
colour), height does: the label's cells within LOW_BAND_M of the clicked cell's height, 8-connected to it, are the
clicked object when they lie LOW_STEP_M or more under the rest of the label (medians), meet it at a step of at least
LOW_EDGE_M (the medians of the cells along their border: a tilted top, a slope, is not cut) and touch the label's
outside (a vessel's floor, enclosed by its wall, is not cut).

Touching objects of the same height AND colour are told apart only by the gap of invalid or darker side cells the
camera sees between them; where none is seen they share one label. A click names the object centred on it
(`centred_on`): when the clicked cell lies more than CENTRE_OFFSET_CELLS from its segment's centroid, that centroid
lies CUT_CENTROID_DEPTH_CELLS or more inside the segment (not off it or on a wall: a ring, a box), and the segment
is not long and thin (the standard deviations of its cells' positions along its minor and major axes in a ratio of
at least CUT_MIN_ROUNDNESS; two blocks side by side: 0.5, a rod or a sliver clicked off its middle: far less), the
segment is cut to its part that is point-symmetric about the click (a cell is kept when its mirror image through the
clicked cell is in the segment too; on the grid, at most a cell's width off). The cut is kept only when what it
leaves is one connected piece of at least CUT_REST_RATIO times its area (a look-alike block beside the clicked one,
not the two ends of a curved object clicked in its middle), or several pieces, the largest that large and each at
least CUT_EXTRA_RATIO times its area, where the kept part fills CUT_SOLIDITY of its convex hull (the clicked block
touching two look-alikes, a bar and a cube, on two sides; not the core of an object with lobes); pieces under
MIN_OBJECT_CELLS or no thicker than a strip of RIM_STRIP_CELLS (the clicked object's own rim, off by a cell) stay
with it. Labels are 1..N, numbered in raster order of their first cell (deterministic for a given heightmap).

Raised: ValueError for a heightmap whose arrays disagree in shape or dtype, and (`segment_at`) for a cell outside
the grid, invalid, on bare table, or on a sliver that belongs to no object.
"""

from __future__ import annotations

import cv2
import numpy as np
from scipy import ndimage

from pg_core.heightmap import Heightmap
from pg_policy.perception.colour_pieces import split_colours
from pg_policy.perception.floors import join_floors
from pg_policy.perception.hubs import join_hubs
from pg_policy.perception.long_pieces import join_pieces

DEPTH_EDGE_M = 0.006  # height bend (m) within a 3 x 3 neighbourhood that makes a depth edge (a 6 mm step)
COLOUR_EDGE = 18.0  # weighted Lab span within a 3 x 3 neighbourhood that makes a colour edge (about 18 delta-E)
LIGHTNESS_WEIGHT = 0.35  # weight of Lab lightness against chroma in the colour span (shading changes lightness)
SEED_ERODE_CELLS = 1  # seeds are shrunk by this many cells (8-neighbourhood) off every edge
MIN_SEED_CELLS = 12  # seed components smaller than this (cells; 0.5 cm^2 at 2 mm) are slivers, not objects
MIN_OBJECT_CELLS = 20  # labels smaller than this (cells) are speckle and dropped to 0
SNAP_RADIUS_CELLS = 2  # `segment_at` on an unlabelled object cell takes the object within this many cells
SEGMENT_HEIGHT_M = 0.004  # cells higher than this (m above the table) hold an object; 8 mm left flat utensils out
THIN_HEIGHT_M = 0.002  # cells higher than this hold an object when their colour stands out from the table's
TABLE_HEIGHT_M = 0.001  # cells this low or lower are table: their median colour is the table's
LOW_BAND_M = 0.006  # a clicked piece: the segment's cells within this height (m) of the clicked cell, connected
LOW_STEP_M = 0.01  # ... that lies this much (m, medians) under the rest of its segment names itself
LOW_EDGE_M = 0.008  # ... and meets the rest at a step this high (m, medians of the cells along their border)
MIN_TABLE_CELLS = 100  # fewer table cells than this in view: the table's colour is unknown (thin cells left out)
CENTRE_OFFSET_CELLS = 5  # `centred_on`: a click this far (1 cm) or nearer to its segment's centroid names it whole
CUT_CENTROID_DEPTH_CELLS = 3.0  # `centred_on`: the segment's centroid lies this far (cells) inside it, or no cut
CUT_MIN_ROUNDNESS = 0.4  # `centred_on`: only a segment this round (minor / major spread) or rounder is cut
CUT_REST_RATIO = 0.5  # `centred_on`: the cut-away rest's largest piece is at least this fraction of the kept part
RIM_STRIP_CELLS = 1.5  # `centred_on`: a cut-away piece no thicker (cells to its edge) is the kept part's rim
CUT_EXTRA_RATIO = 0.25  # `centred_on`: with several cut-away pieces, each is at least this fraction of the kept part
CUT_SOLIDITY = 0.9  # `centred_on`: ... and the kept part fills this share of its convex hull (a block, not a core)
EDGE_LEVELS = 255  # edge strengths are quantised to 0..EDGE_LEVELS for the watershed (uint8)


def _check(hm: Heightmap) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The heightmap's (height float32, colour uint8, valid bool) arrays; ValueError when they disagree."""
    height = np.asarray(hm.height, dtype=np.float32)
    color = np.asarray(hm.color)
    valid = np.asarray(hm.valid, dtype=bool)
    if height.ndim != 2 or valid.shape != height.shape:
        raise ValueError(f"heightmap height {height.shape} and valid {valid.shape} must be the same (H, W)")
    if color.shape != height.shape + (3,) or color.dtype != np.uint8:
        raise ValueError(f"heightmap color must be (H, W, 3) uint8 matching height {height.shape}, got "
                         f"{color.shape} {color.dtype}")
    return height, color, valid


def object_cells(hm: Heightmap) -> np.ndarray:
    """(H, W) bool: the cells that hold an object: the valid cells higher than SEGMENT_HEIGHT_M, and the valid
    cells higher than THIN_HEIGHT_M whose colour lies COLOUR_EDGE or more (weighted Lab, as the edges) from the
    table's, the median colour of the valid cells no higher than TABLE_HEIGHT_M (at least MIN_TABLE_CELLS of them):
    a card, a lid or a thin slab lying flat stands 2-4 mm and is told from the table by its colour."""
    height, color, valid = _check(hm)
    objects = valid & (height > SEGMENT_HEIGHT_M)
    thin = valid & (height > THIN_HEIGHT_M) & ~objects
    table = valid & (height <= TABLE_HEIGHT_M)
    if thin.any() and int(table.sum()) >= MIN_TABLE_CELLS:
        lab = lab_image(color)
        weights = np.array([LIGHTNESS_WEIGHT, 1.0, 1.0], np.float32)
        objects[thin] = np.linalg.norm((lab[thin] - np.median(lab[table], axis=0)) * weights, axis=-1) >= COLOUR_EDGE
    return objects


def lab_image(color: np.ndarray) -> np.ndarray:
    """(H, W, 3) float32 CIE Lab (L in 0..100, a and b about -128..127) of an (H, W, 3) uint8 RGB image."""
    rgb = np.ascontiguousarray(color, dtype=np.uint8).astype(np.float32) / 255.0
    return cv2.cvtColor(rgb, cv2.COLOR_RGB2LAB)


def _span(image: np.ndarray) -> np.ndarray:
    """Per-cell max minus min over the 3 x 3 neighbourhood (morphological gradient) of a float32 image."""
    kernel = np.ones((3, 3), np.uint8)
    return cv2.morphologyEx(image, cv2.MORPH_GRADIENT, kernel, borderType=cv2.BORDER_REPLICATE)


def _bend(height: np.ndarray) -> np.ndarray:
    """Per-cell largest |h(p + d) + h(p - d) - 2 h(p)| over the 4 directions d of the 3 x 3 neighbourhood: 0 on
    any plane, however steep, and the step's height beside a step."""
    pad = cv2.copyMakeBorder(height, 1, 1, 1, 1, cv2.BORDER_REPLICATE)
    h, w = height.shape
    c = pad[1:-1, 1:-1]
    out = np.zeros_like(height)
    for (r1, c1), (r2, c2) in (((0, 1), (2, 1)), ((1, 0), (1, 2)), ((0, 0), (2, 2)), ((0, 2), (2, 0))):
        out = np.maximum(out, np.abs(pad[r1 : r1 + h, c1 : c1 + w] + pad[r2 : r2 + h, c2 : c2 + w] - 2 * c))
    return out


def _colour_strength(lab: np.ndarray) -> np.ndarray:
    """(H, W) float32: the weighted Lab span over each cell's 3 x 3 neighbourhood / COLOUR_EDGE (1.0: a colour
    edge) of an (H, W, 3) float32 Lab image."""
    weights = np.array([LIGHTNESS_WEIGHT, 1.0, 1.0], np.float32)
    spans = np.stack([_span(np.ascontiguousarray(lab[..., i])) for i in range(3)], axis=-1) * weights
    return (np.sqrt((spans**2).sum(axis=-1)) / COLOUR_EDGE).astype(np.float32)


def edge_strength(hm: Heightmap) -> np.ndarray:
    """(H, W) float32 edge strength, 1.0 at the edge thresholds: the larger of the height bend / DEPTH_EDGE_M and
    the weighted Lab span / COLOUR_EDGE over each cell's 3 x 3 neighbourhood; invalid cells are edges (2.0)."""
    height, color, valid = _check(hm)
    return _edge_strength(height, valid, _colour_strength(lab_image(color)))


def _edge_strength(height: np.ndarray, valid: np.ndarray, colour: np.ndarray) -> np.ndarray:
    """`edge_strength` from the checked arrays and the colour part (`_colour_strength`)."""
    depth = _bend(np.where(valid, height, 0.0).astype(np.float32)) / DEPTH_EDGE_M
    strength = np.maximum(depth, colour)
    strength[~valid] = np.maximum(strength[~valid], 2.0)
    return strength.astype(np.float32)


def _seeds(objects: np.ndarray, edges: np.ndarray) -> tuple[np.ndarray, int]:
    """int32 seed labels 1..n of the edge-free object cells (eroded, components >= MIN_SEED_CELLS) and n."""
    core = (objects & ~edges).astype(np.uint8)
    if SEED_ERODE_CELLS > 0:
        core = cv2.erode(core, np.ones((3, 3), np.uint8), iterations=SEED_ERODE_CELLS,
                         borderType=cv2.BORDER_CONSTANT, borderValue=0)
    count, labels, stats, _ = cv2.connectedComponentsWithStats(core, connectivity=8)
    keep = stats[:, cv2.CC_STAT_AREA] >= MIN_SEED_CELLS
    keep[0] = False
    remap = np.zeros(count, np.int32)
    remap[keep] = np.arange(1, int(keep.sum()) + 1, dtype=np.int32)
    return remap[labels], int(keep.sum())


def _renumber(labels: np.ndarray) -> np.ndarray:
    """Labels >= MIN_OBJECT_CELLS cells renumbered 1..N in raster order of their first cell; the rest to 0."""
    flat = labels.ravel()
    ids, first, counts = np.unique(flat, return_index=True, return_counts=True)
    keep = (ids > 0) & (counts >= MIN_OBJECT_CELLS)
    order = ids[keep][np.argsort(first[keep], kind="stable")]
    remap = np.zeros(int(ids.max()) + 1 if len(ids) else 1, np.int32)
    remap[order] = np.arange(1, len(order) + 1, dtype=np.int32)
    return remap[labels]


def segment_objects(hm: Heightmap, lab: np.ndarray | None = None) -> np.ndarray:
    """(H, W) int32 object labels of the heightmap: 0 on table and invalid cells, 1..N one per object found.
    lab: hm's (H, W, 3) float32 Lab image (`lab_image`) when the caller has it already, else it is made here.

    Raises ValueError when the heightmap's arrays disagree in shape or dtype (see the module docstring for the
    method and its limits)."""
    objects = object_cells(hm)
    labels = np.zeros(objects.shape, np.int32)
    if not objects.any():
        return labels
    height, color, valid = _check(hm)
    lab = lab_image(color) if lab is None else lab
    colour = _colour_strength(lab)
    strength = _edge_strength(height, valid, colour)
    seeds, n = _seeds(objects, strength >= 1.0)
    markers = seeds.copy()
    markers[~objects] = n + 1  # the table (and unseen cells): one more basin that stops every object at its rim
    levels = np.clip(strength * (EDGE_LEVELS / 4.0), 0, EDGE_LEVELS).astype(np.uint8)  # 4 x threshold saturates
    flooded = ndimage.watershed_ift(levels, markers, structure=np.ones((3, 3), bool)).astype(np.int32)
    labels = np.where(objects & (flooded <= n), flooded, 0)
    labels = _renumber(_fill_holes(_adopt_orphans(labels, objects & (labels == 0), n), objects))
    weighted = lab * np.array([LIGHTNESS_WEIGHT, 1.0, 1.0], np.float32)
    labels = _renumber(join_hubs(join_floors(labels, height, weighted, COLOUR_EDGE), height, weighted, COLOUR_EDGE))
    labels = _renumber(split_colours(labels, lab[..., 1:], colour, COLOUR_EDGE, MIN_OBJECT_CELLS))
    return _renumber(join_pieces(labels, np.asarray(hm.height, np.float32), np.asarray(hm.valid, bool), weighted,
                                 float(hm.resolution), COLOUR_EDGE))


def _fill_holes(labels: np.ndarray, objects: np.ndarray) -> np.ndarray:
    """Cells off `objects` that one label encloses (a bowl's or cup's floor, lower than SEGMENT_HEIGHT_M, or unseen
    inside it) join that label; object cells are never taken (an object lying in a bowl stays its own)."""
    out = labels.copy()
    for label in np.unique(labels[labels > 0]):
        part = labels == label
        rows, cols = np.nonzero(part)
        r0, r1, c0, c1 = rows.min(), rows.max() + 1, cols.min(), cols.max() + 1
        inside = ndimage.binary_fill_holes(part[r0:r1, c0:c1]) & (labels[r0:r1, c0:c1] == 0) & ~objects[r0:r1, c0:c1]
        out[r0:r1, c0:c1][inside] = label
    return out


def _adopt_orphans(labels: np.ndarray, orphans: np.ndarray, n: int) -> np.ndarray:
    """Object cells the table basin reached first (rims, thin pieces): a piece touching labelled cells joins the
    nearest label cell by cell; a piece touching none becomes a label of its own (numbered after n)."""
    if not orphans.any():
        return labels
    count, parts = cv2.connectedComponents(orphans.astype(np.uint8), connectivity=8)
    grown = cv2.dilate((labels > 0).astype(np.uint8), np.ones((3, 3), np.uint8)).astype(bool)
    touching = np.zeros(count, bool)
    touching[np.unique(parts[grown & orphans])] = True
    touching[0] = False
    out = np.where(orphans & ~touching[parts], parts + n, labels).astype(np.int32)
    if touching.any() and (labels > 0).any():
        _, (near_r, near_c) = ndimage.distance_transform_edt(labels == 0, return_indices=True)
        adopt = orphans & touching[parts]
        out[adopt] = labels[near_r[adopt], near_c[adopt]]
    return out


def segment_at(hm: Heightmap, row: int, col: int, labels: np.ndarray | None = None) -> np.ndarray:
    """(H, W) bool mask of the one object at heightmap cell (row, col).

    labels: the heightmap's `segment_objects` labels when already computed (else computed here).
    Raises ValueError when the cell lies outside the grid, is invalid, is bare table (not higher than
    SEGMENT_HEIGHT_M), or no object label lies within SNAP_RADIUS_CELLS of it.
    """
    height, _, valid = _check(hm)
    rows, cols = height.shape
    if not (0 <= row < rows and 0 <= col < cols):
        raise ValueError(f"cell (row {row}, col {col}) lies outside the {rows} x {cols} heightmap")
    if not valid[row, col]:
        raise ValueError(f"cell (row {row}, col {col}) is invalid (nothing seen there)")
    labels = segment_objects(hm) if labels is None else np.asarray(labels)
    if labels.shape != height.shape:
        raise ValueError(f"labels {labels.shape} do not match the heightmap {height.shape}")
    if height[row, col] <= SEGMENT_HEIGHT_M and labels[row, col] == 0:
        raise ValueError(f"cell (row {row}, col {col}) is bare table: {height[row, col] * 1000:.1f} mm high, "
                         f"objects are higher than {SEGMENT_HEIGHT_M * 1000:.0f} mm")
    label = int(labels[row, col])
    if label != 0:
        own = _own_piece(hm, labels == label, row, col)
        if own is None:
            own = _low_piece(hm, labels == label, row, col)
        if own is not None:
            return own
    if label == 0:
        k = SNAP_RADIUS_CELLS
        r0, c0 = max(row - k, 0), max(col - k, 0)
        window = labels[r0 : row + k + 1, c0 : col + k + 1]
        hits = np.argwhere(window > 0)
        if len(hits) == 0:
            raise ValueError(f"cell (row {row}, col {col}) lies on a sliver that belongs to no object")
        near = hits[np.argmin(((hits - [row - r0, col - c0]) ** 2).sum(axis=1))]
        label = int(window[near[0], near[1]])
    return labels == label


def _own_piece(hm: Heightmap, segment: np.ndarray, row: int, col: int) -> np.ndarray | None:
    """(H, W) bool: the clicked object's part of `segment` (module docstring), or None when the segment holds no
    piece of another chroma."""
    chroma = lab_image(np.asarray(hm.color))[..., 1:]
    k = SNAP_RADIUS_CELLS
    near = np.zeros_like(segment)
    near[max(row - k, 0) : row + k + 1, max(col - k, 0) : col + k + 1] = True
    own = np.median(chroma[segment & near], axis=0)
    alike = segment & (np.linalg.norm(chroma - own, axis=-1) < COLOUR_EDGE)
    if not alike[row, col]:
        return None
    _, parts = cv2.connectedComponents(alike.astype(np.uint8), connectivity=8)
    piece = parts == parts[row, col]
    rest = segment & ~piece
    if rest.sum() < MIN_OBJECT_CELLS or piece.sum() < MIN_OBJECT_CELLS:
        return None
    if float(np.linalg.norm(np.median(chroma[piece], axis=0) - np.median(chroma[rest], axis=0))) < COLOUR_EDGE:
        return None
    return piece


def _low_piece(hm: Heightmap, segment: np.ndarray, row: int, col: int) -> np.ndarray | None:
    """(H, W) bool: the clicked piece of `segment` when it lies LOW_STEP_M or more under the rest (a sliver of an
    object under a neighbour of its colour), or None. The piece: the segment's cells within LOW_BAND_M of the
    clicked cell's height, 8-connected to it; it must touch the segment's outside (a vessel's floor does not)."""
    height = np.asarray(hm.height, np.float32)
    band = segment & (np.abs(height - height[row, col]) <= LOW_BAND_M)
    _, parts = cv2.connectedComponents(band.astype(np.uint8), connectivity=8)
    piece = parts == parts[row, col]
    rest = segment & ~piece
    if rest.sum() < MIN_OBJECT_CELLS or piece.sum() < MIN_OBJECT_CELLS:
        return None
    if float(np.median(height[rest]) - np.median(height[piece])) < LOW_STEP_M:
        return None
    k3 = np.ones((3, 3), np.uint8)
    rest_edge = rest & (cv2.dilate(piece.astype(np.uint8), k3) > 0)
    piece_edge = piece & (cv2.dilate(rest.astype(np.uint8), k3) > 0)
    if float(np.median(height[rest_edge]) - np.median(height[piece_edge])) < LOW_EDGE_M:
        return None  # the two meet on a slope (a tilted top), not at a step
    outside = cv2.dilate((~ndimage.binary_fill_holes(segment)).astype(np.uint8), k3) > 0
    if not (piece & outside).any():
        return None  # enclosed by the rest: a vessel's floor
    return piece


def solidity(mask: np.ndarray) -> float:
    """The area of the (H, W) bool `mask`'s largest outer contour over that of its convex hull (1: convex)."""
    contours, _ = cv2.findContours(mask.astype(np.uint8), cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_NONE)
    if not contours:
        return 0.0
    outline = max(contours, key=cv2.contourArea)
    return float(cv2.contourArea(outline) / max(cv2.contourArea(cv2.convexHull(outline)), 1e-9))


def centred_on(segment: np.ndarray, row: int, col: int) -> np.ndarray:
    """(H, W) bool: the part of the (H, W) bool `segment` centred on its clicked cell (row, col) (module docstring),
    or `segment` itself when the click is near its centroid, the centroid lies off it, or the cut leaves no
    look-alike-sized piece (or a small one beside others). Raises ValueError when (row, col) is not a cell of
    `segment`."""
    segment = np.asarray(segment, bool)
    if not (0 <= row < segment.shape[0] and 0 <= col < segment.shape[1]) or not segment[row, col]:
        raise ValueError(f"cell (row {row}, col {col}) is not in the segment")
    rr, cc = np.nonzero(segment)
    cr, cm = float(rr.mean()), float(cc.mean())
    if np.hypot(cr - row, cm - col) <= CENTRE_OFFSET_CELLS:
        return segment
    inside = cv2.distanceTransform(np.pad(segment, 1).astype(np.uint8), cv2.DIST_L2, 3)[1:-1, 1:-1]
    if inside[int(round(cr)), int(round(cm))] < CUT_CENTROID_DEPTH_CELLS:
        return segment  # the centroid lies off the segment or on a wall of it: a hollow or curved object
    spread = np.linalg.eigvalsh(np.cov(np.stack([rr, cc]).astype(float)))  # ascending: minor, major
    if spread[0] < CUT_MIN_ROUNDNESS**2 * spread[1]:
        return segment  # a long thin segment (a rod, a sliver) clicked off its middle is one object
    mr, mc = 2 * row - rr, 2 * col - cc  # each cell's mirror image through the clicked cell
    inside = (mr >= 0) & (mr < segment.shape[0]) & (mc >= 0) & (mc < segment.shape[1])
    symmetric = np.zeros_like(segment)
    symmetric[rr[inside], cc[inside]] = segment[mr[inside], mc[inside]]
    _, parts = cv2.connectedComponents(symmetric.astype(np.uint8), connectivity=8)
    part = parts == parts[row, col]
    rest = segment & ~part
    n_rest, rest_parts = cv2.connectedComponents(rest.astype(np.uint8), connectivity=8)
    sizes = np.bincount(rest_parts.ravel())
    sizes[0] = 0  # the background
    depth = cv2.distanceTransform(np.pad(rest, 1).astype(np.uint8), cv2.DIST_L2, 3)[1:-1, 1:-1]
    thick = np.asarray(ndimage.maximum(depth, rest_parts, np.arange(n_rest)))  # a piece's half-width (cells)
    # smaller or thinner ones are the clicked object's own rim cells, off by a cell of the mirror image
    pieces = np.nonzero((sizes >= MIN_OBJECT_CELLS) & (thick > RIM_STRIP_CELLS))[0]
    kept = int(part.sum())
    if kept < MIN_OBJECT_CELLS or len(pieces) == 0 or sizes[pieces].max() < CUT_REST_RATIO * kept:
        return segment
    if len(pieces) > 1 and ((sizes[pieces] < CUT_EXTRA_RATIO * kept).any() or solidity(part) < CUT_SOLIDITY):
        return segment  # a small piece beside a large one (a handle), or the core of a lobed object: one object
    return segment & ~np.isin(rest_parts, pieces)
