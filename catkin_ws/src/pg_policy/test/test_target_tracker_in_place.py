"""pg_policy.perception.target_tracker, a target that did not move ("in place"): it keeps its cells when a look-alike
comes to lie against it, does not grow into a look-alike beside it in one segment, and grows by what a removed
cover uncovers; something that moves onto it leaves it partly covered."""

from __future__ import annotations

import numpy as np
from tracker_testing import BLUE, GEO, RED
from tracker_testing import blocks as _blocks
from tracker_testing import iou as _iou

from pg_core.heightmap import Heightmap
from pg_policy.perception.target_tracker import TargetTracker


def test_a_target_that_did_not_move_keeps_its_cells_when_a_look_alike_is_pushed_against_it():
    tracker = TargetTracker()
    first = _blocks((100, 100, RED), (100, 160, RED))
    target = np.zeros((224, 224), bool)
    target[100:120, 100:120] = True
    tracker.start(first, target)
    track = tracker.update(_blocks((100, 100, RED), (100, 120, RED)), (0.0, 0.0))  # now touching: one segment
    assert np.array_equal(track.mask, target) and not track.unsure
    assert "in place" in track.why and "touching object left out" in track.why


def test_a_target_in_place_does_not_grow_into_a_look_alike_beside_it_in_one_segment():
    view = _blocks((100, 100, RED), (100, 120, RED))  # two touching look-alikes: one segment of 800 cells
    first = np.zeros((224, 224), bool)
    first[100:120, 100:118] = True  # the first mask: most of the left block (360 cells)
    tracker = TargetTracker()
    tracker.start(view, first)
    track = tracker.update(view, (0.0, 0.0))  # nothing moved (an action elsewhere)
    assert "in place" in track.why and not track.mask[:, 120:].any(), track.why  # over twice its area: not grown


def test_a_large_target_uncovered_grows_to_two_and_a_half_times_what_was_seen():
    def view(covered: bool) -> Heightmap:
        height = np.zeros((224, 224), np.float32)
        colour = np.full((224, 224, 3), 200, np.uint8)
        height[100:140, 100:140], colour[100:140, 100:140] = 0.03, RED  # an 8 x 8 cm block
        if covered:
            height[96:144, 116:150], colour[96:144, 116:150] = 0.05, BLUE  # a higher block over 60 % of it
        return Heightmap(colour, height, np.ones((224, 224), bool), GEO.heightmap.resolution, GEO.workspace.bounds)

    first = np.zeros((224, 224), bool)
    first[100:140, 100:116] = True  # the 40 % in view
    tracker = TargetTracker()
    tracker.start(view(True), first)
    track = tracker.update(view(False))  # the cover is gone: 2.5 times the area first seen, over UNCOVERED_MAX_M2
    truth = np.zeros((224, 224), bool)
    truth[100:140, 100:140] = True
    assert _iou(track.mask, truth) >= 0.9 and "in place" in track.why and "uncovered" in track.why, track.why


def test_a_target_that_did_not_move_grows_by_what_a_removed_neighbour_uncovers():
    first = _blocks((100, 100, RED))
    first.height[100:120, 110:130] = 0.05  # a higher blue block covers the target's right half
    first.color[100:120, 110:130] = BLUE
    target = np.zeros((224, 224), bool)
    target[100:120, 100:110] = True
    tracker = TargetTracker()
    tracker.start(first, target)
    track = tracker.update(_blocks((100, 100, RED)))  # the blue block is gone
    truth = np.zeros((224, 224), bool)
    truth[100:120, 100:120] = True
    assert _iou(track.mask, truth) >= 0.9 and "in place" in track.why


def test_a_target_mostly_covered_in_its_first_view_grows_to_all_a_removed_cover_uncovers():
    first = _blocks((100, 100, RED))
    first.height[96:124, 104:130] = 0.05  # a higher blue block covers all but a 4-cell strip of the target
    first.color[96:124, 104:130] = BLUE
    target = np.zeros((224, 224), bool)
    target[100:120, 100:104] = True
    tracker = TargetTracker()
    tracker.start(first, target)
    track = tracker.update(_blocks((100, 100, RED)))  # the cover is gone: 5 times the area first seen
    truth = np.zeros((224, 224), bool)
    truth[100:120, 100:120] = True
    assert _iou(track.mask, truth) >= 0.9 and "in place" in track.why and "uncovered" in track.why, track.why


def test_a_target_something_moves_onto_keeps_its_visible_part_and_is_in_place_when_uncovered():
    first = _blocks((100, 100, RED), (100, 160, RED))  # the target and a look-alike 2 cm away
    target = np.zeros((224, 224), bool)
    target[100:120, 100:120] = True
    tracker = TargetTracker()
    tracker.start(first, target)
    half = _blocks((100, 100, RED), (100, 160, RED))
    half.height[100:120, 110:130], half.color[100:120, 110:130] = 0.05, BLUE  # a blue block lands on its right half
    track = tracker.update(half)
    assert not track.unsure and "partly covered" in track.why, track.why
    assert track.mask[100:120, 100:108].all() and not track.mask[:, 110:].any()
    whole = _blocks((100, 100, RED), (100, 160, RED))
    whole.height[96:124, 96:124], whole.color[96:124, 96:124] = 0.05, BLUE  # ... and then covers all of it
    track = tracker.update(whole)
    assert not track.mask.any() and track.unsure and track.why.startswith("covered"), track.why
    track = tracker.update(_blocks((100, 100, RED), (100, 160, RED)))  # the cover is gone
    assert _iou(track.mask, target) >= 0.9 and "in place" in track.why and not track.unsure, track.why
