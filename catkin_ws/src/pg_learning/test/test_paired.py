"""pg_learning.evaluation.paired: trials matched on (scene, seed), discordant completions, exact sign test, GS
difference."""

import pytest

from pg_learning.evaluation.paired import paired, sign_test_p
from pg_policy.target_loop.records import TrialRecord


def _t(scene, seed, completed, grasps=1, target_grasps=None):
    hits = (1 if completed else 0) if target_grasps is None else target_grasps
    return TrialRecord(scene=scene, seed=seed, completed=completed, grasps=grasps, target_grasps=hits)


def test_sign_test_p_is_the_exact_two_sided_binomial():
    assert sign_test_p(0, 0) == 1.0
    assert sign_test_p(5, 0) == pytest.approx(2 / 32)
    assert sign_test_p(0, 5) == pytest.approx(2 / 32)
    assert sign_test_p(1, 8) == pytest.approx(20 / 512)  # 2 * (1 + 9) / 2^9
    assert sign_test_p(4, 4) == pytest.approx(1.0)
    with pytest.raises(ValueError, match=">= 0"):
        sign_test_p(-1, 2)


def test_paired_matches_scene_and_seed_and_ignores_unmatched_trials():
    a = [_t("packed/case01", 1, True), _t("packed/case01", 2, True), _t("random-10", 1, False, 2, 0),
         _t("random-10", 9, False)]
    b = [_t("packed/case01", 1, False, 2, 0), _t("packed/case01", 2, True, 2, 1), _t("random-10", 1, True),
         _t("random-20", 9, True)]
    r = paired(a, b)
    assert (r.n, r.a_only, r.b_only) == (3, 1, 1)
    assert r.p_c == pytest.approx(1.0)
    # GS_A - GS_B per pair: 1 - 0, 1 - 0.5, 0 - 1
    assert r.gs_diff.mean == pytest.approx((1 + 0.5 - 1) / 3)
    assert r.gs_diff.n == 3


def test_paired_skips_trials_without_grasps_in_the_gs_difference_and_refuses_duplicates():
    a = [_t("household/case11", 1, False, 0, 0), _t("household/case11", 2, True)]
    b = [_t("household/case11", 1, True), _t("household/case11", 2, True)]
    r = paired(a, b)
    assert (r.a_only, r.b_only, r.gs_diff.n) == (0, 1, 1)
    with pytest.raises(ValueError, match="appears twice"):
        paired(a + a[:1], b)
