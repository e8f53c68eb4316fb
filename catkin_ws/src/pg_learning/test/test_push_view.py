"""pg_learning.evaluation.push_view: a watched push yields one frame per `every` metres of its stroke, the robot's
own cells hold no data in them, the counts are the target's cells in view, and bad arguments are refused."""

from __future__ import annotations

import json

import numpy as np
import pytest

from pg_learning.evaluation.push_view import WatchedPush, main, summary, watch_push


def test_a_watched_push_sees_the_robot_removed_and_counts_the_target(tmp_path):
    push = watch_push("packed/case03", 5000, every_m=0.026)
    assert len(push.visible) == len(push.views) == 5  # the 0.13 m stroke, a frame every 0.026 m
    assert push.cells_before > 200
    for (hm, seen), n in zip(push.views, push.visible, strict=True):
        assert int(seen.sum()) == n <= 2 * push.cells_before
        assert not seen[~hm.valid].any()  # the target is counted only where the camera sees it
    assert min(int((~hm.valid).sum()) for hm, _ in push.views) > 500  # the arm's cells: no data, not its heights
    assert all(float(hm.height[hm.valid].max()) < 0.2 for hm, _ in push.views)  # no arm in the heightmap
    assert main(["--scenes", "packed/case03", "--seeds", "1", "--every", "0.026", "--out", str(tmp_path)]) == 0
    saved = json.loads((tmp_path / "push_view.json").read_text())
    assert saved["pushes"][0]["visible"] == push.visible  # deterministic: the same seed, the same push
    assert (tmp_path / "push_view.png").stat().st_size > 1000


def test_the_summary_counts_shares_of_frames():
    pushes = [WatchedPush("a", 1, 0.0, 100, [100, 50, 0, 0]), WatchedPush("b", 2, 1.0, 10, [1, 10])]
    s = summary(pushes)
    assert s["frames"] == 6 and s["none"] == pytest.approx(2 / 6, abs=1e-3) and s["half_or_more"] == 0.5
    assert s["median_share"] == pytest.approx(float(np.median([1.0, 0.5, 0.0, 0.0, 0.1, 1.0])), abs=1e-3)
    assert summary([])["frames"] == 0


@pytest.mark.parametrize("bad", [["--seeds", "0"], ["--every", "0"], ["--behind", "-0.01"]])
def test_bad_arguments_are_refused(tmp_path, bad):
    with pytest.raises(SystemExit):
        main(["--scenes", "packed/case01", "--out", str(tmp_path), *bad])
    assert not (tmp_path / "push_view.json").exists()
