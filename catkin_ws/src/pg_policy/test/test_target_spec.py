"""pg_policy.target_loop.target_spec: a bad target spec, or one the heightmap refuses (a point off the workspace or
on the bare table, a mask of another shape or on the table only), is refused with a ValueError naming the field."""

from __future__ import annotations

import numpy as np
import pytest

from pg_core.geometry import load
from pg_core.heightmap import Heightmap
from pg_policy.target_loop.target_spec import ColourTarget, MaskTarget, PointTarget, TargetFollower

GEO = load()


def _flat(shape: tuple[int, int] = (224, 224)) -> Heightmap:
    height = np.zeros(shape, np.float32)
    height[100:120, 100:120] = 0.04  # one 4 x 4 cm block
    return Heightmap(np.full(shape + (3,), 120, np.uint8), height, np.ones(shape, bool), GEO.heightmap.resolution,
                     GEO.workspace.bounds)


@pytest.mark.parametrize("make, field", [
    (lambda: ColourTarget("octarine"), "ColourTarget.name"),
    (lambda: PointTarget(float("nan"), 0.0), "PointTarget.x"),
    (lambda: MaskTarget(np.zeros((224, 224), bool)), "MaskTarget.mask"),
    (lambda: MaskTarget(np.ones(5, bool)), "MaskTarget.mask"),
])
def test_bad_specs_are_refused_naming_the_field(make, field):
    with pytest.raises(ValueError, match=field.replace(".", r"\.")):
        make()


@pytest.mark.parametrize("spec, field", [
    (PointTarget(0.5, 0.0), "PointTarget.x"),
    (PointTarget(0.0, -0.3), "PointTarget.y"),
    (PointTarget(-0.15, -0.15), "PointTarget"),  # bare table
    (MaskTarget(np.ones((10, 10), bool)), "MaskTarget.mask"),  # another shape than the heightmap
    (MaskTarget(np.pad(np.ones((5, 5), bool), ((0, 219), (0, 219)))), "MaskTarget.mask"),  # on table only
])
def test_specs_the_heightmap_refuses_name_the_field(spec, field):
    with pytest.raises(ValueError, match=field.replace(".", r"\.")):
        TargetFollower(spec).mask(_flat())


def _labels() -> np.ndarray:
    """Segments of a 40 x 40 grid: 1, two look-alikes side by side in one segment (rows 0-9, cols 0-19 and
    20-39); 2, a ring around 3, its raised hub (rows 20-39)."""
    labels = np.zeros((40, 40), np.int32)
    labels[0:10, 0:40] = 1
    labels[20:40, 0:20] = 2
    labels[26:34, 6:14] = 3
    return labels


def test_a_mask_on_one_of_two_look_alikes_in_one_segment_names_that_one():
    from pg_policy.target_loop.target_spec import mask_object

    labels = _labels()
    mask = np.zeros_like(labels, bool)
    mask[0:10, 0:21] = True  # the left block, one column over the seam
    assert np.array_equal(mask_object(labels, mask), mask)
    mask[10:30, 0:21] = True  # a loose mask, most of it on the table (and a corner of the ring): the segment whole
    mask[20:30, 0:21] = False
    assert np.array_equal(mask_object(labels, mask), labels == 1)


def test_a_mask_over_most_of_segments_takes_them_whole():
    from pg_policy.target_loop.target_spec import mask_object

    labels = _labels()
    mask = np.zeros_like(labels, bool)
    mask[21:39, 1:20] = True  # ring and hub, a ragged border short of the ring's edge
    assert np.array_equal(mask_object(labels, mask), np.isin(labels, (2, 3)))
    mask[10:12, 0:5] = True  # a few table cells: left out
    assert np.array_equal(mask_object(labels, mask), np.isin(labels, (2, 3)))


def test_a_mask_spread_thinly_names_the_segment_holding_most_of_it():
    from pg_policy.target_loop.target_spec import mask_object

    labels = np.repeat(np.arange(1, 6, dtype=np.int32), 8)[None, :].repeat(40, axis=0)  # five stripes, 320 cells each
    mask = np.zeros_like(labels, bool)
    for k, cells in enumerate((4, 4, 4, 4, 5)):  # no stripe holds a quarter of the mask, the last the most
        mask[0:cells, 8 * k] = True
    assert np.array_equal(mask_object(labels, mask), labels == 5)
    with pytest.raises(ValueError, match=r"MaskTarget\.mask covers no object"):
        mask_object(np.where(labels == 1, 0, labels), labels == 1)
