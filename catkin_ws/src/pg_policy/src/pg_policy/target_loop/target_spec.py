"""How a request names its target, and the per-observation target mask that follows from it (no ROS).

A request names its target in one of three ways:
- `ColourTarget(name)`: the object painted palette colour `name`; every observation's mask is
  pg_core.target_mask.target_mask(color, valid, name), exactly as for a colour request before;
- `PointTarget(x, y)`: the object under the point (x, y), metres in `world` (e.g. a click on the camera image
  projected to the table); on the first observation the mask is pg_policy.perception.segmentation.segment_at of the
  point's cell, cut at the necks where look-alikes touch it (pg_policy.perception.necks.cut_at_neck) and then to
  the object centred on the point (`centred_on`: a look-alike touching it side by side in one segment is left
  out), and, with a learned segmenter (`segmenter` "shipped" or a model file; the default "none" has none), joined
  with the segments it takes for parts of the same object
  (pg_policy.models.click_segmentation.ClickSegmentation.join_clicked); on later
  ones pg_policy.perception.target_tracker.TargetTracker keeps it on the same object, the point's cell its anchor
  (the part of the first mask that stays when a look-alike beside it moves away);
- `MaskTarget(mask)`: the object a (H, W) bool mask over the heightmap grid covers; on the first observation the
  mask is refined by the segmentation (`mask_object`): a segment it covers three quarters of is taken whole, and of
  a segment holding a quarter or more of it but covered less, the part it covers (look-alikes of one colour and
  height side by side are one segment); then it is tracked as a point is.

`TargetFollower(spec, push_length)` turns the spec plus successive heightmaps (`mask(hm)`) into the target masks;
`acted(...)` after each action predicts where an executed push carried the target (pg_policy.perception.push_shift)
for the next update, so a pushed target is looked for where the push left it; `unsure` and `why` tell the decision
record whether the latest track is in doubt and why (always sure for colours).
Masks are (H, W) bool over the heightmap cells (pg_core.heightmap: rows along y, columns along x).

Raised: ValueError naming the field (`ColourTarget.name`, `PointTarget.x`, `PointTarget.y`, `PointTarget`,
`MaskTarget.mask`) for an unknown colour, a non-finite coordinate, a point outside the heightmap, a point on bare
table or invalid cells, an empty mask, a mask of another shape than the heightmap or one covering no object; the
spec's own checks run at construction, the ones that need a heightmap on the first `mask` call.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from pg_core.heightmap import Heightmap, world_to_pixel
from pg_core.target_mask import hsv_window, target_mask
from pg_policy.models.click_segmentation import DEFAULT_SEGMENTER, load_segmenter
from pg_policy.perception.necks import cut_at_neck
from pg_policy.perception.push_shift import push_shift
from pg_policy.perception.segmentation import centred_on, segment_at, segment_objects
from pg_policy.perception.target_tracker import TargetTracker, Track

MASK_WHOLE_SHARE = 0.75  # a mask that covers this share of a segment names the segment whole
MASK_PART_SHARE = 0.25  # ... and one of whose object cells this share lie in a segment names its part there
MASK_TABLE_SHARE = 0.5  # ... unless this share of its cells is table: a loose mask names the segment whole


@dataclass(frozen=True)
class ColourTarget:
    """The object painted palette colour `name` (pg_core.palette; case-insensitive, ``grey`` accepted)."""

    name: str = "green"

    def __post_init__(self) -> None:
        try:
            hsv_window(self.name)
        except ValueError as exc:
            raise ValueError(f"ColourTarget.name: {exc}") from None


@dataclass(frozen=True)
class PointTarget:
    """The object under world point (x, y), metres in `world`."""

    x: float
    y: float

    def __post_init__(self) -> None:
        for name in ("x", "y"):
            if not math.isfinite(float(getattr(self, name))):
                raise ValueError(f"PointTarget.{name} must be a finite number of metres, got {getattr(self, name)}")


@dataclass(frozen=True, eq=False)
class MaskTarget:
    """The object that (H, W) bool `mask` over the heightmap grid covers (`mask_object`)."""

    mask: np.ndarray = field(repr=False)

    def __post_init__(self) -> None:
        mask = np.asarray(self.mask)
        if mask.ndim != 2:
            raise ValueError(f"MaskTarget.mask must be an (H, W) bool array, got shape {mask.shape}")
        if not mask.astype(bool).any():
            raise ValueError("MaskTarget.mask is empty: it marks no cell")


TargetSpec = ColourTarget | PointTarget | MaskTarget


def point_cell(hm: Heightmap, target: PointTarget) -> tuple[int, int]:
    """(row, col) of the cell under `target`; ValueError naming PointTarget.x / .y when it lies off the grid."""
    rows, cols = np.asarray(hm.height).shape
    row, col = world_to_pixel(target.x, target.y, hm.bounds, hm.resolution)
    b = hm.bounds
    if not 0 <= col < cols:
        raise ValueError(f"PointTarget.x = {target.x:.3f} m lies outside the heightmap's x range "
                         f"[{b[0, 0]:.3f}, {b[0, 1]:.3f}] m")
    if not 0 <= row < rows:
        raise ValueError(f"PointTarget.y = {target.y:.3f} m lies outside the heightmap's y range "
                         f"[{b[1, 0]:.3f}, {b[1, 1]:.3f}] m")
    return row, col


def first_mask(hm: Heightmap, target: PointTarget | MaskTarget, segmenter: str = DEFAULT_SEGMENTER) -> np.ndarray:
    """(H, W) bool: the object a point or mask target names in its first heightmap (see the module docstring);
    `segmenter`: the learned segmenter joining a point's parts (pg_policy.models.click_segmentation.load_segmenter:
    "none", the default, "shipped" or a model file)."""
    labels = segment_objects(hm)
    if isinstance(target, PointTarget):
        row, col = point_cell(hm, target)
        try:
            segment = segment_at(hm, row, col, labels)
        except ValueError as exc:
            raise ValueError(f"PointTarget ({target.x:.3f}, {target.y:.3f}) m names no object: {exc}") from None
        first = segment if not segment[row, col] else centred_on(cut_at_neck(segment, row, col), row, col)
        learned = load_segmenter(segmenter)
        return first if learned is None else learned.join_clicked(hm, labels, first, row, col)
    mask = np.asarray(target.mask).astype(bool)
    if mask.shape != labels.shape:
        raise ValueError(f"MaskTarget.mask shape {mask.shape} differs from the heightmap's {labels.shape}")
    return mask_object(labels, mask)


def mask_object(labels: np.ndarray, mask: np.ndarray) -> np.ndarray:
    """(H, W) bool: the object a mask names, from the (H, W) int segment `labels` (0: table) and the (H, W) bool
    `mask`. A segment the mask covers MASK_WHOLE_SHARE of is taken whole (the segmentation's edges replace a
    projected mask's ragged ones). A segment holding MASK_PART_SHARE of the mask's object cells, of which the mask
    covers less, is taken as far as the mask covers it: look-alikes of one colour and height side by side are one
    segment, and the mask names one of them; but a loose mask (MASK_TABLE_SHARE of its cells on the table) names
    that segment whole. Failing both (the mask spread thinly over several segments), the segment holding most of
    its cells (ties: the lower label). Raises ValueError naming MaskTarget.mask when it covers no object cell."""
    counts = np.bincount(labels[mask], minlength=int(labels.max()) + 1)
    counts[0] = 0
    if counts.max() == 0:
        raise ValueError("MaskTarget.mask covers no object: all its cells are table or invalid")
    sizes = np.bincount(labels.ravel(), minlength=counts.size)
    loose = counts.sum() <= (1.0 - MASK_TABLE_SHARE) * mask.sum()
    out = np.zeros_like(mask)
    for label in np.nonzero(counts)[0]:
        if counts[label] >= MASK_WHOLE_SHARE * sizes[label]:
            out |= labels == label
        elif counts[label] >= MASK_PART_SHARE * counts.sum():
            out |= labels == label if loose else mask & (labels == label)
    return out if out.any() else labels == int(np.argmax(counts))


class TargetFollower:
    """The per-observation target mask of one request: `mask(hm)` for each heightmap in turn, `acted(...)` after
    each action. push_length: m a push travels (the geometry's primitives.push_length); None: no displacement is
    ever predicted (the tracker looks for the target where it was last seen). segmenter: `first_mask`'s. Raises
    ValueError for another spec type, FileNotFoundError for a segmenter model file that is not there."""

    def __init__(self, spec: TargetSpec, push_length: float | None = None, segmenter: str = DEFAULT_SEGMENTER) -> None:
        if not isinstance(spec, ColourTarget | PointTarget | MaskTarget):
            raise ValueError(f"target must be a ColourTarget, PointTarget or MaskTarget, got {type(spec).__name__}")
        self.spec = spec
        self.push_length = push_length
        self.segmenter = segmenter
        load_segmenter(segmenter)  # a missing model file is refused here, before any heightmap
        self.tracker = TargetTracker()
        self.track: Track | None = None  # the latest track (None for colours and before the first observation)
        self.shift: tuple[float, float] | None = None  # predicted displacement for the next update (m, `world`)
        self._last: tuple[Heightmap, np.ndarray] | None = None  # the latest heightmap and its mask

    def mask(self, hm: Heightmap, shift_xy: tuple[float, float] | None = None) -> np.ndarray:
        """(H, W) bool target mask in `hm` (empty: not seen). shift_xy: the target's displacement (dx, dy) in
        `world` metres since the previous heightmap when the caller knows it; None: the one `acted` predicted (or
        none). Ignored for colours and on the first observation. Raises ValueError naming the spec's field when the
        first heightmap refuses it."""
        spec = self.spec
        if isinstance(spec, ColourTarget):
            return target_mask(hm.color, hm.valid, spec.name)
        if self.track is None:
            anchor = point_cell(hm, spec) if isinstance(spec, PointTarget) else None
            self.track = self.tracker.start(hm, first_mask(hm, spec, self.segmenter), anchor)
        else:
            self.track = self.tracker.update(hm, shift_xy if shift_xy is not None else self.shift)
        self.shift = None
        self._last = (hm, self.track.mask)
        return self.track.mask

    def acted(self, primitive: str, x: float, y: float, yaw: float, executed: bool) -> None:
        """Record the action just taken on the latest heightmap (`primitive` "push" or "grasp" at (x, y) m in
        `world`, yaw rad; `executed`: it ran): an executed push predicts that the target moved by push_shift of the
        latest mask; anything else predicts no move."""
        self.shift = None
        if primitive == "push" and executed and self.push_length is not None and self._last is not None:
            hm, mask = self._last
            self.shift = push_shift(mask, hm, x, y, yaw, self.push_length)

    @property
    def unsure(self) -> bool:
        """Whether the latest track is in doubt (never for colour targets or before the first observation)."""
        return self.track is not None and self.track.unsure

    @property
    def why(self) -> str:
        """One line for the decision record: how the latest target mask was found."""
        if isinstance(self.spec, ColourTarget):
            return f"colour {self.spec.name}"
        return self.track.why if self.track is not None else "not observed yet"
