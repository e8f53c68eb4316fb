"""pg_learning.evaluation.track_replay: a recorded trial replays to the masks the trial tracked (the same IoU at
every step as its record says), the segment bound scores the best whole segment, and a folder without recorded
trials or an unknown scene is refused."""

from __future__ import annotations

import json

import numpy as np
import pytest

from pg_core.geometry import load
from pg_core.heightmap import Heightmap
from pg_learning.evaluation.track_replay import (
    main,
    record,
    replay_trial,
    segment_bound,
    summary,
    true_shift,
)


def test_a_recorded_trial_replays_to_the_masks_it_tracked(tmp_path):
    assert record(["packed/case05"], 5001, 1, tmp_path, allow_train_seeds=True) == 1
    trial = json.loads((tmp_path / "trials.jsonl").read_text().splitlines()[1])["trial"]
    recorded = [a["target"]["iou"] for a in trial["actions"]]
    replayed = replay_trial(tmp_path / "packed_case05_5001.npz", load().primitives.push_length)
    assert [s["iou"] for s in replayed["steps"]][: len(recorded)] == recorded
    s = summary([replayed])
    assert 0 < s["steps"] <= len(replayed["steps"]) and s["found"] <= s["steps"]
    assert record(["packed/case05"], 5001, 1, tmp_path, allow_train_seeds=True) == 0  # kept: resumable
    saved = tmp_path / "replay.json"
    assert main(["replay", str(tmp_path), "--save", str(saved)]) == 0
    assert [s["iou"] for s in json.loads(saved.read_text())[0]["steps"]] == [s["iou"] for s in replayed["steps"]]
    masked = replay_trial(tmp_path / "packed_case05_5001.npz", load().primitives.push_length, "mask", True)
    assert masked["steps"][0]["iou"] >= 0.9 and len(masked["steps"]) == len(replayed["steps"])  # named by its mask
    assert main(["replay", str(tmp_path), "--target-by", "mask", "--known-shift"]) == 0
    bounded = replay_trial(tmp_path / "packed_case05_5001.npz", load().primitives.push_length, bound=True)
    assert [s["iou"] for s in bounded["steps"]] == [s["iou"] for s in replayed["steps"]]  # the tracker untouched
    assert all(0.0 <= s["segment_iou"] <= 1.0 and s["segment"] in ("whole", "merged", "split", "mixed", "none")
               for s in bounded["steps"])
    b = summary([bounded])
    assert b["segment"] + b["no_segment"] == b["steps"] and b["found_segment"] <= b["segment"]
    assert b["first_steps"] == 1 and b["first_segment"] + b["first_no_segment"] == 1
    assert sum(b[f"no_segment_{k}"] for k in ("merged", "split", "mixed", "none")) == b["no_segment"]
    assert main(["replay", str(tmp_path), "--segment-bound"]) == 0


def _blocks(colour: tuple[int, int, int], gap: int) -> tuple[Heightmap, np.ndarray]:
    """Two 3 x 3 cm blocks 4 cm high, the left one grey, the right one `colour`, `gap` cells apart; and the left
    block's mask (the target's ground truth)."""
    geo = load()
    height = np.zeros((224, 224), np.float32)
    color = np.full((224, 224, 3), 200, np.uint8)
    height[100:115, 90:105] = height[100:115, 105 + gap : 120 + gap] = 0.04
    color[100:115, 90:105], color[100:115, 105 + gap : 120 + gap] = (128, 128, 128), colour
    truth = np.zeros((224, 224), bool)
    truth[100:115, 90:105] = True
    return Heightmap(color, height, np.ones((224, 224), bool), geo.heightmap.resolution, geo.workspace.bounds), truth


def test_the_segment_bound_is_the_best_whole_segment():
    assert segment_bound(*_blocks((200, 40, 40), 0)) == (pytest.approx(1.0), "whole")  # another colour
    assert segment_bound(*_blocks((128, 128, 128), 5)) == (pytest.approx(1.0), "whole")  # apart
    assert segment_bound(*_blocks((128, 128, 128), 0)) == (pytest.approx(0.5, abs=0.05), "merged")  # seamless
    hm, truth = _blocks((200, 40, 40), 0)
    both = truth | np.roll(truth, 15, axis=1)  # the truth spans both blocks: each segment is a piece of it
    assert segment_bound(hm, both) == (pytest.approx(0.5, abs=0.05), "split")
    assert segment_bound(hm, np.roll(truth, 60, axis=0)) == (0.0, "none")  # nothing there


def test_the_true_shift_is_the_move_of_the_ground_truth_centroid():
    before = np.zeros((50, 50), bool)
    before[10:20, 10:20] = True
    after = np.roll(before, (5, -3), axis=(0, 1))  # 5 rows along +y, 3 columns along -x
    assert true_shift(before, after, 0.002) == pytest.approx((-0.006, 0.010))
    assert true_shift(before, np.zeros_like(before), 0.002) is None  # not in view: nothing known


def test_an_evaluation_seed_check_and_an_empty_folder_are_refused(tmp_path):
    with pytest.raises(ValueError):
        record(["packed/case05"], 5001, 1, tmp_path)  # a training seed without --allow-train-seeds
    with pytest.raises(SystemExit):
        main(["replay", str(tmp_path)])
    with pytest.raises(ValueError, match="packed/case99"):
        record(["packed", "packed/case99"], 5001, 1, tmp_path / "out", allow_train_seeds=True)
    assert not (tmp_path / "out").exists()  # refused before anything is written
