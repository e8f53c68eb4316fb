"""pg_policy.perception.segmentation.centred_on: a click names the object centred on it. Two blocks of one colour
and height touching side by side are one segment; a click at the centre of one of them names that block alone
(also where look-alikes touch it on two sides),
while a click near the middle of a single object, off the middle of a long thin one, on an object whose centroid
lies off it, or in the middle of a curved one keeps the segment whole."""

from __future__ import annotations

import numpy as np
import pytest

from pg_policy.perception.segmentation import centred_on

SIDE = 22  # cells: a 45 mm block at 2 mm per cell


def _iou(a: np.ndarray, b: np.ndarray) -> float:
    return float((a & b).sum() / max((a | b).sum(), 1))


def _blocks(*origins: tuple[int, int], size: tuple[int, int] = (SIDE, SIDE)) -> tuple[np.ndarray, list[np.ndarray]]:
    """(segment, the blocks' own masks) of axis-aligned blocks with top-left cells `origins` on a 100 x 100 grid."""
    blocks = []
    for r, c in origins:
        m = np.zeros((100, 100), bool)
        m[r : r + size[0], c : c + size[1]] = True
        blocks.append(m)
    return np.logical_or.reduce(blocks), blocks


@pytest.mark.parametrize("which", [0, 1])
def test_a_click_at_one_of_two_touching_blocks_names_that_block(which):
    segment, blocks = _blocks((30, 20), (30, 20 + SIDE))  # side by side: one segment of 22 x 44 cells
    rows, cols = np.nonzero(blocks[which])
    mask = centred_on(segment, int(rows.mean()), int(cols.mean()))
    assert _iou(mask, blocks[which]) >= 0.9 and (mask & blocks[1 - which]).sum() <= SIDE  # one column at most
    assert not np.array_equal(mask, segment)


def _grid(*boxes: tuple[int, int, int, int]) -> list[np.ndarray]:
    """Masks of axis-aligned boxes (row, col, rows, cols) on a 120 x 120 grid."""
    out = []
    for r, c, h, w in boxes:
        m = np.zeros((120, 120), bool)
        m[r : r + h, c : c + w] = True
        out.append(m)
    return out


def test_a_click_at_a_block_between_two_look_alikes_names_that_block():
    # a bar with a cube on one long side and another bar on the other, both towards its left end: three objects,
    # one segment, and the two look-alikes do not touch each other (two pieces once the clicked bar is cut out)
    bar, cube, other = _grid((50, 30, SIDE, 2 * SIDE), (28, 24, SIDE, SIDE), (72, 10, SIDE, 2 * SIDE))
    segment = bar | cube | other
    rows, cols = np.nonzero(bar)
    mask = centred_on(segment, int(rows.mean()), int(cols.mean()))
    assert _iou(mask, bar) >= 0.9 and (mask & cube).sum() <= SIDE and not (mask & other).any()  # a cube's row at most


def test_an_object_with_lobes_clicked_beside_its_core_is_kept_whole():
    # three widening arms from a small core, like a novel part: clicked off its centre, the point-symmetric part is
    # the core and two arms are left as pieces, but the core fills less of its convex hull than a block does
    rr, cc = np.mgrid[:120, :120]
    lobed = np.hypot(rr - 60, cc - 60) < 8
    for angle in (90.0, 210.0, 330.0):
        a = np.radians(angle)
        along = (rr - 60) * np.sin(a) + (cc - 60) * np.cos(a)
        across = -(rr - 60) * np.cos(a) + (cc - 60) * np.sin(a)
        lobed |= (along > 0) & (along < 20) & (np.abs(across) < 6 + 0.2 * along)
    for row, col in ((58, 54), (66, 56)):
        assert np.array_equal(centred_on(lobed, row, col), lobed)


def test_a_small_piece_beside_a_look_alike_keeps_the_segment_whole():
    # beside the look-alike, a piece a tenth of the clicked object's area (a handle or a spout of the object's
    # own, not an object): the cut is not trusted
    block, other, nub = _grid((50, 20, SIDE, SIDE), (50, 20 + SIDE, SIDE, SIDE), (44, 24, 6, 8))
    segment = block | other | nub
    rows, cols = np.nonzero(block)
    assert np.array_equal(centred_on(segment, int(rows.mean()), int(cols.mean())), segment)


def test_a_long_thin_segment_clicked_off_its_middle_is_kept_whole():
    segment, blocks = _blocks((10, 5), (10, 5 + SIDE), (10, 5 + 2 * SIDE))  # three in a row: 1 x 3, like a rod
    rows, cols = np.nonzero(blocks[0])
    assert np.array_equal(centred_on(segment, int(rows.mean()), int(cols.mean())), segment)
    rod, _ = _blocks((50, 10), size=(6, 80))
    assert np.array_equal(centred_on(rod, 52, 20), rod)


def test_a_click_near_the_middle_of_one_object_keeps_it_whole():
    segment, _ = _blocks((30, 20), size=(20, 60))
    assert np.array_equal(centred_on(segment, 40, 50), segment)  # the centroid (39.5, 49.5)
    assert np.array_equal(centred_on(segment, 42, 46), segment)  # 4 cells off: within CENTRE_OFFSET_CELLS


def test_an_object_whose_centroid_lies_off_it_is_kept_whole():
    arch, _ = _blocks((20, 20), size=(40, 40))
    arch[20:45, 32:48] = False  # a U: the centroid falls in the notch
    assert np.array_equal(centred_on(arch, 50, 26), arch)


def test_a_curved_object_clicked_in_its_middle_is_kept_whole():
    rr, cc = np.mgrid[:100, :100]
    radius = np.hypot(rr - 80, cc - 50)
    banana = (radius > 35) & (radius < 45) & (rr < 75)  # an arc: the centroid lies on it, off its middle
    mid_r = int(np.nonzero(banana[:, 50])[0].mean())
    assert np.array_equal(centred_on(banana, mid_r, 50), banana)  # the two ends are two pieces: no cut


def test_a_cell_outside_the_segment_is_refused():
    segment, _ = _blocks((30, 20))
    with pytest.raises(ValueError, match="not in the segment"):
        centred_on(segment, 0, 0)
    with pytest.raises(ValueError, match="not in the segment"):
        centred_on(segment, 200, 5)


@pytest.mark.parametrize(("scene", "seed"), [("packed/case09", 5001), ("packed/case07", 5003)])
def test_a_point_at_a_packed_block_names_it_where_a_look_alike_touches_it(scene, seed):
    """Packed scenes repainted so that colours repeat (`pushgrasp eval --colours repeated`): the target touches a
    block of its colour and height, both in one segment; the point at its centre (as `--target-by point` clicks)
    names the target alone."""
    from pg_core.geometry import load
    from pg_learning.environment.sim_env import SimEnv
    from pg_learning.evaluation.runner import DEFAULT_JITTER_XY, DEFAULT_JITTER_YAW, trial_scene
    from pg_learning.evaluation.target_by import centre_point
    from pg_policy.perception.segmentation import segment_at, segment_objects
    from pg_policy.target_loop.target_spec import first_mask, point_cell

    with SimEnv(load(), colours="repeated") as env:
        obs = env.reset(trial_scene(scene, seed, DEFAULT_JITTER_XY, DEFAULT_JITTER_YAW), seed)
    hm, truth = obs.heightmap, obs.truth_target
    point = centre_point(hm, truth)
    segment = segment_at(hm, *point_cell(hm, point), segment_objects(hm))
    assert _iou(segment, truth) < 0.5  # the look-alike shares the target's segment
    assert _iou(first_mask(hm, point), truth) >= 0.8
