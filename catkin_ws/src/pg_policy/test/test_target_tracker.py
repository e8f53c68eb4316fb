"""pg_policy.perception.target_tracker and pg_policy.target_loop.target_spec: a target named by a point or a mask
stays on the same object while a real (PyBullet) push moves it, even when every object has the same colour; a colour
target gives exactly pg_core.target_mask.target_mask (the specs' refusals: test_target_spec.py)."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest
from tracker_testing import BLUE, GEO, RED
from tracker_testing import blocks as _blocks
from tracker_testing import iou as _iou

from pg_core.heightmap import Heightmap, pixel_to_world
from pg_core.target_mask import target_mask
from pg_policy.perception.target_tracker import TargetTracker
from pg_policy.target_loop.target_spec import ColourTarget, MaskTarget, PointTarget, TargetFollower

PUSH_Z = 0.01  # push height of the fingertips above the table (m)
BEHIND = 0.05  # the push starts this far (m) behind the target's centre, along the push
PUSH_SHIFT = 0.10  # the displacement (m) the push predicts for the target: 0.13 m travel less 0.03 m to reach it
MIN_MOVE = 0.03  # the push must move the target at least this far (m) for the test to mean anything
MIN_IOU = 0.7
SAME_RGB = (190, 60, 50)  # every object's colour in the one-colour scene


def _scene(same_colour: bool) -> Any:
    """A loose cluster: the target cube at the origin, another cube of the same size beside the push's end, a rect,
    a cylinder and a half cube; in palette colours or all one colour."""
    from pg_sim.scenes.colors import resolve_color
    from pg_sim.scenes.scene import ObjectSpec, SceneSpec

    layout = [("cube", "green", (0.0, 0.0), True), ("cube", "blue", (0.09, 0.075), False),
              ("rect", "yellow", (0.02, -0.075, ), False), ("cylinder", "orange", (-0.07, 0.06), False),
              ("half_cube", "purple", (-0.08, -0.06), False)]
    objs = tuple(ObjectSpec(shape, None, SAME_RGB if same_colour else resolve_color(colour), (x, y, 0.03, 0, 0, 0.2),
                            target=target, name=f"{shape}_{i}")
                 for i, (shape, colour, (x, y), target) in enumerate(layout))
    return SceneSpec("tracking", "green", objs, "test")


def _centroid_m(hm: Heightmap, mask: np.ndarray) -> np.ndarray:
    rows, cols = np.nonzero(mask)
    return np.array(pixel_to_world(rows.mean(), cols.mean(), hm.bounds, hm.resolution))


@pytest.fixture(scope="module")
def pushes() -> dict[bool, tuple[Any, Any, Any]]:
    """same_colour -> (observation before, observation after a +x push through the target, target start (x, y))."""
    from pg_learning.environment.sim_env import SimEnv

    out = {}
    with SimEnv(GEO) as env:
        for same in (False, True):
            before = env.reset(_scene(same))
            x, y = _centroid_m(before.heightmap, before.truth_target)
            res = env.step("push", x - BEHIND, y, PUSH_Z, 0.0)
            assert res.executed, res.message
            out[same] = (before, env.observe(), (x, y))
    return out


@pytest.mark.parametrize("same_colour", [False, True], ids=["palette", "one-colour"])
@pytest.mark.parametrize("predicted", [True, False], ids=["shift", "no-shift"])
def test_the_tracked_mask_follows_the_pushed_target(pushes, same_colour, predicted):
    before, after, _ = pushes[same_colour]
    moved = np.linalg.norm(_centroid_m(after.heightmap, after.truth_target) -
                           _centroid_m(before.heightmap, before.truth_target))
    assert moved >= MIN_MOVE
    tracker = TargetTracker()
    tracker.start(before.heightmap, before.truth_target)
    track = tracker.update(after.heightmap, (PUSH_SHIFT, 0.0) if predicted else None)
    iou = _iou(track.mask, after.truth_target)
    assert iou >= MIN_IOU, (moved, iou, track)
    assert 0.0 <= track.confidence <= 1.0 and track.why
    assert _iou(track.mask, before.truth_target) < 0.5  # it moved with the object, not stayed behind
    if predicted:
        assert not track.unsure, track.why
    else:  # 11 cm from where it was seen, as far as another cube alike: in doubt, and saying so
        assert track.unsure and "weak match" in track.why


@pytest.mark.parametrize("same_colour", [False, True], ids=["palette", "one-colour"])
def test_a_point_target_follows_the_pushed_object(pushes, same_colour):
    before, after, (x, y) = pushes[same_colour]
    follower = TargetFollower(PointTarget(x, y))
    first = follower.mask(before.heightmap)
    assert _iou(first, before.truth_target) >= MIN_IOU and not follower.unsure
    later = follower.mask(after.heightmap, (PUSH_SHIFT, 0.0))
    assert _iou(later, after.truth_target) >= MIN_IOU, follower.why
    assert isinstance(follower.unsure, bool) and follower.why


@pytest.mark.parametrize("same_colour", [False, True], ids=["palette", "one-colour"])
def test_the_follower_predicts_where_its_executed_push_carried_the_target(pushes, same_colour):
    before, after, (x, y) = pushes[same_colour]
    follower = TargetFollower(PointTarget(x, y), GEO.primitives.push_length)
    follower.mask(before.heightmap)
    follower.acted("push", x - BEHIND, y, 0.0, executed=False)  # refused: nothing moved
    assert follower.shift is None
    follower.acted("push", x - BEHIND, y, 0.0, executed=True)
    assert follower.shift is not None and follower.shift[0] == pytest.approx(PUSH_SHIFT, abs=0.02)
    later = follower.mask(after.heightmap)
    assert _iou(later, after.truth_target) >= MIN_IOU and not follower.unsure, follower.why
    assert follower.shift is None  # a prediction serves one update


def test_a_mask_target_is_refined_to_the_object_it_mostly_covers(pushes):
    before, _, _ = pushes[True]
    rows, cols = np.nonzero(before.truth_target)
    rough = np.zeros_like(before.truth_target)
    rough[rows.min() + 3 : rows.max() - 3, cols.min() + 3 : cols.max() + 6] = True  # a loose box, part table
    follower = TargetFollower(MaskTarget(rough))
    assert _iou(follower.mask(before.heightmap), before.truth_target) >= MIN_IOU


def test_a_hidden_target_gives_an_empty_unsure_track(pushes):
    before, _, _ = pushes[False]
    tracker = TargetTracker()
    tracker.start(before.heightmap, before.truth_target)
    hm = before.heightmap
    bare = Heightmap(np.zeros_like(hm.color), np.zeros_like(hm.height), hm.valid, hm.resolution, hm.bounds)
    track = tracker.update(bare)
    assert not track.mask.any() and track.unsure and track.confidence == 0.0


def test_the_colour_path_is_target_mask(pushes):
    before, after, _ = pushes[False]
    follower = TargetFollower(ColourTarget("green"))
    for obs in (before, after):
        hm = obs.heightmap
        assert np.array_equal(follower.mask(hm, (0.05, 0.0)), target_mask(hm.color, hm.valid, "green"))
    assert not follower.unsure and follower.why == "colour green"


def _flat(shape: tuple[int, int] = (224, 224)) -> Heightmap:
    height = np.zeros(shape, np.float32)
    height[100:120, 100:120] = 0.04  # one 4 x 4 cm block
    return Heightmap(np.full(shape + (3,), 120, np.uint8), height, np.ones(shape, bool), GEO.heightmap.resolution,
                     GEO.workspace.bounds)


def test_update_before_start_and_a_mismatched_mask_are_refused():
    with pytest.raises(RuntimeError):
        TargetTracker().update(_flat())
    with pytest.raises(ValueError, match="shape"):
        TargetTracker().start(_flat(), np.ones((3, 3), bool))


def test_a_target_carried_beyond_reach_is_re_found_by_appearance_or_as_the_look_alike_nearest_its_last_place():
    tracker = TargetTracker()
    first = _blocks((20, 20, RED), (150, 150, BLUE))
    tracker.start(first, (np.asarray(first.height) > 0) & (np.arange(224)[:, None] < 100))
    track = tracker.update(_blocks((20, 170, RED), (150, 150, BLUE)))  # 30 cm away: beyond every gate
    assert track.mask[25, 175] and not track.mask[155, 155] and track.unsure and "re-found" in track.why
    for far, near in (((150, 150), (20, 170)), ((20, 200), (100, 100))):  # two alike, nothing where it was expected
        tracker = TargetTracker()
        tracker.start(first, (np.asarray(first.height) > 0) & (np.arange(224)[:, None] < 100))
        track = tracker.update(_blocks((far[0], far[1], RED), (near[0], near[1], RED)))
        assert track.mask[near[0] + 5, near[1] + 5] and not track.mask[far[0] + 5, far[1] + 5], track.why
        assert track.unsure and "nearest where it was last sure" in track.why
    tracker = TargetTracker()
    tracker.start(first, (np.asarray(first.height) > 0) & (np.arange(224)[:, None] < 100))
    track = tracker.update(_blocks((20, 20, BLUE), (20, 170, RED), (150, 150, RED)))  # something lies there: hidden
    assert not track.mask.any() and "not found" in track.why, track.why


def test_a_target_carried_beyond_reach_is_re_found_among_what_moved_not_in_a_look_alike_that_did_not():
    tracker = TargetTracker()
    first = _blocks((20, 20, RED), (150, 150, RED))
    tracker.start(first, (np.asarray(first.height) > 0) & (np.arange(224)[:, None] < 100))
    track = tracker.update(_blocks((20, 170, RED), (150, 150, RED)))  # the look-alike stayed where it was
    assert track.mask[25, 175] and not track.mask[155, 155] and track.unsure and "re-found" in track.why
    track = tracker.update(_blocks((20, 170, RED), (150, 150, RED)))  # still compared with where it was last found
    assert track.mask[25, 175] and not track.mask[155, 155], track.why
    tracker = TargetTracker()
    tracker.start(first, (np.asarray(first.height) > 0) & (np.arange(224)[:, None] < 100))
    track = tracker.update(_blocks((20, 170, RED), (150, 100, RED)))  # both moved: not told apart by appearance,
    assert track.mask[25, 175] and "nearest where it was last sure" in track.why, track.why  # by where it was


def test_a_target_left_behind_by_a_track_on_a_look_alike_is_re_found_among_all_objects_once_that_is_lifted():
    from pg_policy.perception.segmentation import lab_image

    tracker = TargetTracker()
    first = _blocks((20, 20, RED), (150, 150, RED))
    tracker.start(first, (np.asarray(first.height) > 0) & (np.arange(224)[:, None] < 100))
    carried = _blocks((20, 170, RED), (150, 150, RED))  # a push carried the target 30 cm; unsure tracks went ...
    look_alike = np.zeros((224, 224), bool)
    look_alike[150:170, 150:170] = True
    tracker._found(carried, look_alike, lab_image(carried.color))  # ... onto the look-alike ...
    track = tracker.update(_blocks((20, 170, RED)))  # ... which a grasp then lifted; the target did not move since
    assert track.mask[25, 175] and track.unsure and "among all objects" in track.why, track.why


def test_a_target_turned_onto_another_face_beyond_reach_is_re_found_as_the_one_object_of_its_colour():
    tracker = TargetTracker()
    first = _blocks((20, 20, RED), (150, 150, BLUE))
    tracker.start(first, (np.asarray(first.height) > 0) & (np.arange(224)[:, None] < 100))
    turned = _blocks((20, 170, RED), (20, 190, RED), (150, 150, BLUE))  # 30 cm away, twice as long: not its form
    track = tracker.update(turned)
    assert track.mask[25, 175] and track.mask[25, 205] and track.unsure and "one object of its colour" in track.why, (
        track.why)
    tracker = TargetTracker()
    tracker.start(first, (np.asarray(first.height) > 0) & (np.arange(224)[:, None] < 100))
    track = tracker.update(_blocks((20, 170, RED), (20, 190, RED), (150, 150, RED), (150, 170, RED)))
    assert not track.mask.any() and "not found" in track.why  # two of its colour: neither is taken


def test_when_the_tracked_object_is_lifted_the_unmoved_look_alike_beside_it_is_the_target():
    tracker = TargetTracker()
    first = _blocks((100, 100, RED), (100, 130, RED), (20, 200, RED))
    wrong = np.zeros((224, 224), bool)
    wrong[100:120, 100:120] = True  # the track was on the wrong block, which a grasp then lifted
    tracker.start(first, wrong)
    track = tracker.update(_blocks((100, 130, RED), (20, 200, RED)))
    assert track.mask[105:115, 135:145].all() and not track.mask[20:40, 200:220].any(), track.why


def test_after_unsure_tracks_led_to_a_look_alike_that_was_lifted_the_target_is_found_where_it_was_last_sure():
    first = _blocks((100, 100, RED), (100, 180, RED), (20, 20, RED))
    target = np.zeros((224, 224), bool)
    target[100:120, 100:120] = True
    tracker = TargetTracker()
    tracker.start(first, target)
    tracker.last_mask = np.zeros_like(target)  # as unsure tracks leave it: on the look-alike 16 cm away ...
    tracker.last_mask[100:120, 180:200] = True
    track = tracker.update(_blocks((100, 100, RED), (20, 20, RED)))  # ... which a grasp then lifted
    assert _iou(track.mask, target) >= 0.9 and track.unsure and "last sure" in track.why, track.why


def test_a_target_mostly_covered_in_its_first_view_is_found_when_a_push_uncovers_and_moves_it():
    first = _blocks((100, 100, RED))
    first.height[96:124, 104:130], first.color[96:124, 104:130] = 0.05, BLUE  # a blue block covers the target
    target = np.zeros((224, 224), bool)
    target[100:120, 100:104] = True
    tracker = TargetTracker()
    tracker.start(first, target)
    after = _blocks((100, 115, RED), (155, 100, RED))  # the cover pushed away, the target carried 3 cm, and a
    after.height[155:175, 104:120] = 0.0  # red 4 x 20 cell strip (the form first seen) pushed in 11 cm away
    track = tracker.update(after, (0.0, 0.0))
    truth = np.zeros((224, 224), bool)
    truth[100:120, 115:135] = True
    assert _iou(track.mask, truth) >= 0.9, track.why


def _block(hm: Heightmap, row: int, col: int, size: int, height: float, rgb: tuple[int, int, int]) -> None:
    """A `size` x `size` cell block of `height` (m) and colour `rgb` in `hm`, first cell (row, col)."""
    hm.height[row : row + size, col : col + size], hm.color[row : row + size, col : col + size] = height, rgb


@pytest.mark.parametrize("moved", [False, True], ids=["in-place", "pushed"])
def test_a_block_mostly_covered_in_its_first_view_grows_to_its_whole_top_when_uncovered(moved):
    """A 4.6 cm block (529 cells, the size of the protocol's cubes) seen as a 6-cell strip under a cover, then
    uncovered where it lay, or uncovered and carried 3 cm: the track takes in its whole top, not the strip."""
    first = _blocks()
    _block(first, 100, 100, 23, 0.03, RED)
    _block(first, 96, 106, 30, 0.05, BLUE)  # a higher blue block covers all but a 6-cell strip of the target
    target = np.zeros((224, 224), bool)
    target[100:123, 100:106] = True
    tracker = TargetTracker()
    tracker.start(first, target)
    after, col = _blocks(), 115 if moved else 100
    _block(after, 100, col, 23, 0.03, RED)
    track = tracker.update(after, (0.0, 0.0))
    truth = np.zeros((224, 224), bool)
    truth[100:123, col : col + 23] = True
    assert _iou(track.mask, truth) >= 0.9, track.why


def _pushed_beside_a_look_alike(before: tuple[int, int], after: tuple[int, int], shift_x: float) -> tuple[Any, Any]:
    """Two red 20-cell blocks in row 100, the target first: their first columns `before`, then `after` a push
    along +x predicted to carry the target `shift_x` m. The track of the second view and the target's true mask."""
    tracker = TargetTracker()
    target = np.zeros((224, 224), bool)
    target[100:120, before[0] : before[0] + 20] = True
    tracker.start(_blocks((100, before[0], RED), (100, before[1], RED)), target)
    track = tracker.update(_blocks((100, after[0], RED), (100, after[1], RED)), (shift_x, 0.0))
    truth = np.zeros((224, 224), bool)
    truth[100:120, after[0] : after[0] + 20] = True
    return track, truth


def test_a_target_pushed_into_the_place_a_look_alike_left_is_tracked_whole():
    """The target pushed 12 cells into the place of a look-alike (one colour, one height) that the same push carried
    on: the cells where the look-alike lay look unchanged, but the look-alike's segment moved away, so they are the
    target's, not an unmoved neighbour's (a disc pushed into a cube's place in packed scenes)."""
    track, truth = _pushed_beside_a_look_alike((100, 124), (112, 150), 0.048)
    assert _iou(track.mask, truth) >= 0.9, track.why


def test_a_target_a_push_carried_less_far_than_predicted_is_told_from_the_look_alike_it_pushed_on():
    """A push predicted to carry the target 30 cells carries it 10, into a look-alike that it shoves 20 cells on:
    the target lies a third of the way along the predicted displacement and is found there, sure, not the
    look-alike nearer the predicted end."""
    track, truth = _pushed_beside_a_look_alike((60, 84), (70, 104), 0.06)
    assert _iou(track.mask, truth) >= 0.9 and not track.unsure, track.why


def test_extent_tells_a_disc_from_a_square_at_any_angle():
    import cv2

    from pg_policy.perception.target_appearance import extent

    disc = np.zeros((224, 224), np.uint8)
    cv2.circle(disc, (100, 100), 11, 1, -1)
    assert 0.72 <= extent(disc.astype(bool)) <= 0.8
    for angle in (0.0, 10.0, 22.5, 45.0):
        square = np.zeros((224, 224), np.uint8)
        box = cv2.boxPoints(((100.0, 100.0), (23.0, 23.0), angle))
        cv2.fillPoly(square, [np.round(box).astype(np.int32)], 1)
        assert extent(square.astype(bool)) >= 0.88, angle


def test_a_point_target_first_seen_merged_with_a_look_alike_is_the_clicked_part_once_the_look_alike_moves():
    """Two red blocks side by side, one segment (no gap): the first mask holds both; the click was at (110, 110).
    A push carries the right one 10 cells on, to where two thirds of the displacement predicted from the merged mask
    lead: the block under the click did not move and is the target (without the clicked cell, the look-alike is),
    and its form becomes the reference."""
    first = _blocks((100, 100, RED), (100, 120, RED))
    merged = np.asarray(first.height) > 0
    after = _blocks((100, 100, RED), (100, 130, RED))
    truth = np.zeros((224, 224), bool)
    truth[100:120, 100:120] = True
    tracker = TargetTracker()
    tracker.start(first, merged)
    assert _iou(tracker.update(after, (0.06, 0.0)).mask, truth) < 0.5
    tracker = TargetTracker()
    tracker.start(first, merged, (110, 110))
    track = tracker.update(after, (0.06, 0.0))
    assert np.array_equal(track.mask, truth) and "clicked part" in track.why, track.why
    assert tracker.reference is not None and tracker.reference.area == 400
    track = tracker.update(_blocks((100, 160, RED), (20, 20, RED)), (0.12, 0.0))  # now the target is pushed
    assert track.mask[105:115, 165:175].all() and tracker.anchor is None, track.why


def test_the_anchor_is_kept_only_inside_the_first_mask():
    first = _blocks((100, 100, RED))
    tracker = TargetTracker()
    tracker.start(first, np.asarray(first.height) > 0, (10, 10))
    assert tracker.anchor is None
    with pytest.raises(ValueError, match="anchor"):
        tracker.start(first, np.asarray(first.height) > 0, (224, 10))
