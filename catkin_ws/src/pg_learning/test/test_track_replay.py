"""pg_learning.evaluation.track_replay: a recorded trial replays to the masks the trial tracked (the same IoU at
every step as its record says), and a folder without recorded trials or an unknown scene is refused."""

from __future__ import annotations

import json

import numpy as np
import pytest

from pg_core.geometry import load
from pg_learning.evaluation.track_replay import main, record, replay_trial, summary, true_shift


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
