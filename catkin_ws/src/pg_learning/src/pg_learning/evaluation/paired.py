"""Paired comparison of two policies on the same trials (same scene, same seed, hence the same initial scene).

`pushgrasp eval` seeds every trial's scene from (scene, seed) alone, so two policies' trials with equal keys start
from the identical scene: their difference is measured trial by trial, which is far less noisy than comparing two
means whose standard errors each include the scene-to-scene spread.

- Completion: over the common trials, ``a_only`` = trials only A completed, ``b_only`` = only B completed (a trial
  that ended in an error, termination "error", is not completed). Under
  "no difference" each discordant trial is equally likely to go either way, so the two-sided exact sign test
  (binomial, p = 0.5 over a_only + b_only trials; McNemar's exact test) gives the p value.
- Grasp success: the mean and standard error of the per-trial difference GS_A - GS_B over the common trials where
  both attempted a grasp.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

from pg_policy.target_loop.metrics import Stat, mean_se
from pg_policy.target_loop.records import TrialRecord


@dataclass(frozen=True)
class PairedResult:
    """n: common trials; a_only / b_only: trials completed by one policy only; p_c: two-sided exact sign-test p of
    completion (1.0 without discordant trials); gs_diff: per-trial GS_A - GS_B (fractions) over common trials where
    both grasped."""

    n: int
    a_only: int
    b_only: int
    p_c: float
    gs_diff: Stat


def sign_test_p(a_only: int, b_only: int) -> float:
    """Two-sided exact binomial p of a_only successes in a_only + b_only trials at p = 0.5 (1.0 when both are 0).
    Raises ValueError for negative counts."""
    if a_only < 0 or b_only < 0:
        raise ValueError(f"counts must be >= 0, got {a_only}, {b_only}")
    if a_only + b_only == 0:
        return 1.0
    from scipy.stats import binomtest

    return float(binomtest(a_only, a_only + b_only, 0.5).pvalue)


def paired(a: Sequence[TrialRecord], b: Sequence[TrialRecord]) -> PairedResult:
    """Compare A's and B's trials matched on (scene, seed); trials without a partner are ignored.

    Raises ValueError when a (scene, seed) occurs twice in one policy's trials.
    """
    index_b = _index(b, "B")
    pairs = [(t, index_b[k]) for k, t in _index(a, "A").items() if k in index_b]
    a_only = sum(ta.completed and not tb.completed for ta, tb in pairs)
    b_only = sum(tb.completed and not ta.completed for ta, tb in pairs)
    diffs = [ta.grasp_success - tb.grasp_success for ta, tb in pairs
             if ta.grasp_success is not None and tb.grasp_success is not None]
    return PairedResult(len(pairs), a_only, b_only, sign_test_p(a_only, b_only), mean_se(diffs))


def _index(trials: Sequence[TrialRecord], which: str) -> dict[tuple[str, int], TrialRecord]:
    out: dict[tuple[str, int], TrialRecord] = {}
    for t in trials:
        key = (t.scene, int(t.seed))
        if key in out:
            raise ValueError(f"policy {which}: trial {key} appears twice")
        out[key] = t
    return out
