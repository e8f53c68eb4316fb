"""pg_policy.perception.necks.cut_at_neck: objects of one colour and height that meet at a corner or a narrow
contact share one segment; a click on one of them names it alone, cut where the outline narrows. A single object
with thin parts (a mug's handle, a spoon), two pieces of one long object joined across a gap, and two blocks side
by side (no neck: `centred_on` tells those apart) are left whole."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from pg_policy.perception.necks import cut_at_neck


def _iou(a: np.ndarray, b: np.ndarray) -> float:
    return float((a & b).sum() / max((a | b).sum(), 1))


def _square(centre: tuple[float, float], side: float, angle_deg: float, shape=(120, 120)) -> np.ndarray:
    """(H, W) bool: a filled square of `side` cells centred at (row, col), turned by angle_deg."""
    box = cv2.boxPoints(((centre[1], centre[0]), (side, side), angle_deg))
    m = np.zeros(shape, np.uint8)
    cv2.fillPoly(m, [np.round(box).astype(np.int32)], 1)
    return m.astype(bool)


def _disc(centre: tuple[float, float], radius: float, shape=(120, 120)) -> np.ndarray:
    rr, cc = np.mgrid[: shape[0], : shape[1]]
    return np.hypot(rr - centre[0], cc - centre[1]) <= radius


def test_a_cylinder_between_two_blocks_touching_it_at_their_corners_is_named_alone():
    """packed: a cylinder of one colour with a block on either side, each touching it with a corner (the segment is
    as symmetric about the click as the cylinder alone, so `centred_on` cannot cut it)."""
    cylinder = _disc((60, 60), 13)
    left = _square((60, 60 - 13 - 11), 22, 45)  # a corner of each block reaches into the cylinder
    right = _square((60, 60 + 13 + 11), 22, 45)
    segment = cylinder | left | right
    mask = cut_at_neck(segment, 60, 60)
    assert _iou(mask, cylinder) >= 0.85
    assert (mask & (left | right) & ~cylinder).sum() <= 10
    assert _iou(cut_at_neck(segment, 60, 60 + 13 + 11), right) >= 0.8  # a click on a block names the block


def test_a_block_touching_another_at_a_corner_is_named_alone_wherever_it_is_clicked():
    a, b = _square((40, 40), 24, 45), _square((40, 66), 24, 0)  # a's corner reaches 3 cells into b's side
    segment = a | b
    assert cv2.connectedComponents(segment.astype(np.uint8))[0] == 2  # one piece (and the background)
    for row, col in ((40, 40), (34, 44), (46, 36), (40, 28)):
        assert _iou(cut_at_neck(segment, row, col), a) >= 0.85
    assert _iou(cut_at_neck(segment, 40, 70), b) >= 0.85


def test_two_blocks_side_by_side_have_no_neck_and_stay_whole():
    segment = np.zeros((120, 120), bool)
    segment[30:52, 20:64] = True  # two 22-cell blocks sharing a whole face
    assert np.array_equal(cut_at_neck(segment, 41, 31), segment)


def test_one_object_with_thin_parts_stays_whole():
    mug = _disc((60, 50), 20)
    mug |= _disc((60, 74), 9) & ~_disc((60, 74), 5)  # a handle ring 4 cells thick
    assert np.array_equal(cut_at_neck(mug, 60, 50), mug)
    spoon = _disc((60, 30), 10)
    spoon[57:63, 38:100] = True  # the handle: 6 cells wide, a half-width under MIN_PEAK_CELLS
    assert np.array_equal(cut_at_neck(spoon, 60, 30), spoon)
    assert np.array_equal(cut_at_neck(spoon, 60, 80), spoon)  # a click on the thin handle: nothing is cut


def test_pieces_of_one_segment_apart_from_each_other_stay_together():
    """A segment joined across a gap (a rod seen on both sides of an object lying across it) is not cut apart."""
    segment = _disc((40, 30), 14) | _disc((40, 90), 14)
    assert np.array_equal(cut_at_neck(segment, 40, 30), segment)


def test_a_cell_outside_the_segment_is_refused():
    segment = _disc((60, 60), 10)
    with pytest.raises(ValueError, match="not in the segment"):
        cut_at_neck(segment, 0, 0)
    with pytest.raises(ValueError, match="not in the segment"):
        cut_at_neck(segment, 300, 5)


@pytest.mark.parametrize(("scene", "seed"), [("packed/case02", 5001), ("packed/case06", 5006)])
def test_a_point_at_a_packed_target_names_it_where_look_alikes_meet_it_at_a_neck(scene, seed):
    """Packed scenes repainted so that colours repeat (`pushgrasp eval --colours repeated`), training seeds: the
    target and blocks of its colour and height touching it at a narrow contact are one segment; the point at the
    target's centre (as `--target-by point` clicks) names the target alone."""
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
    assert _iou(segment, truth) < 0.5  # look-alikes share the target's segment
    assert _iou(first_mask(hm, point), truth) >= 0.7
