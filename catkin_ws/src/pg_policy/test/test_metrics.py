"""pg_policy.target_loop.metrics: C, GS and MN (DESIGN.md section 8) over episode records, on a hand-computed case."""

from __future__ import annotations

import math

import pytest

from pg_policy.target_loop.metrics import Stat, fmt, mean_se, scene_metrics, summarize
from pg_policy.target_loop.records import TrialRecord, plain, record_from_dict


def _trial(completed, pushes, grasps, target_grasps, scene="a", refused=0):
    return TrialRecord(scene, 0, completed, "completed" if completed else "max_actions", grasps, target_grasps,
                       grasps - target_grasps, pushes, refused, [{}] * (pushes + grasps + refused))


def test_metrics_on_a_hand_computed_case():
    trials = [_trial(True, 2, 2, 1), _trial(True, 0, 1, 1), _trial(False, 3, 5, 0), _trial(False, 30, 0, 0)]
    m = scene_metrics(trials)
    # C: values 1,1,0,0 -> mean 0.5, sd sqrt(1/3), se sqrt(1/3)/2
    assert (m["C"].mean, m["C"].n) == (0.5, 4) and m["C"].se == pytest.approx(math.sqrt(1 / 3) / 2)
    # GS over trials with attempts: 0.5, 1, 0 -> mean 0.5, sd 0.5, se 0.5/sqrt(3)
    assert (m["GS"].mean, m["GS"].n) == (0.5, 3) and m["GS"].se == pytest.approx(0.5 / math.sqrt(3))
    # MN over completed trials: pushes 2, 0 -> mean 1, sd sqrt(2), se 1
    assert (m["MN"].mean, m["MN"].n) == (1.0, 2) and m["MN"].se == pytest.approx(1.0)
    assert m["gs_completed"].mean == pytest.approx(0.75) and m["actions_completed"].mean == pytest.approx(2.5)
    assert mean_se([]).mean is None and mean_se([0.3]).se is None
    s = summarize(trials + [_trial(True, 1, 1, 1, scene="b")])
    assert list(s) == ["a", "b", "all"] and s["all"]["C"].n == 5 and "all" not in summarize(trials)


def test_fmt_and_the_json_form_of_records():
    assert fmt(Stat(0.5, 0.125, 4), 100) == "50.0 ± 12.5" and fmt(Stat(1.0, None, 1)) == "1.0 ± n/a"
    assert fmt(Stat(None, None, 0)) == "n/a"
    rec = _trial(True, 2, 2, 1)
    back = record_from_dict(plain(rec.to_dict()))
    assert back == rec and plain({"q": float("nan"), "s": Stat(0.5, None, 1)}) == {"q": None, "s": {
        "mean": 0.5, "se": None, "n": 1}}
