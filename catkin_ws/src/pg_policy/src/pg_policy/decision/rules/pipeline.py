"""The ordered chain of test-time rules between the learned nets' Q maps and the decision.

For each Q map (grasp, then push) the pipeline applies, in the configured order, the `adjust` of every rule on that
map, then re-ranks the map once by the conjunction of the rules' candidate tests (pg_policy.decision.rerank): the
best-valued candidate inside the primitive's region that passes every test takes the map's best value, so the
grasp-or-push decision (masked max vs the threshold) is unchanged by the tests; when none of the best `top_k`
passes, the map is left as it was and a vetoing grasp rule asks the policy to push instead. When the policy must
grasp all the same (its push budget is spent), `forced_grasp` re-ranks Q_g by the rules' weaker fallback tests.
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from pg_policy.decision.rerank import rerank
from pg_policy.decision.rules.rule import BatchTest, CandidateTest, Rule, RuleContext

FORCED_TOP_K = 1000  # candidates examined per fallback level of a forced grasp


@dataclass(frozen=True)
class RuleOutcome:
    """q: the adjusted maps {"grasp", "push"} the decision uses; shown: the maps after the "filter" rules only (what
    the policy shows users as its Q maps); push_instead: a vetoing grasp rule found no passing grasp; note: why;
    rejected: per map, the candidates ranked above the one that passed every test (0: the best passed, or no tests);
    vetoed: per map, candidate tests ran and no candidate of a non-empty region passed."""

    q: dict[str, np.ndarray]
    shown: dict[str, np.ndarray]
    push_instead: bool
    note: str
    rejected: dict[str, int]
    vetoed: dict[str, bool]


def conjunction(tests: Sequence[CandidateTest]) -> CandidateTest:
    """The candidate test passed when every one of `tests` passes (evaluated in order, stopping at the first no).
    A BatchTest when every test is one: each later test is asked only about the candidates the earlier ones passed."""
    if tests and all(isinstance(t, BatchTest) for t in tests):
        def many(rots: np.ndarray, rows: np.ndarray, cols: np.ndarray) -> np.ndarray:
            ok = np.ones(len(rots), dtype=bool)
            for t in tests:
                idx = np.flatnonzero(ok)
                if idx.size == 0:
                    break
                ok[idx] = np.asarray(t.many(rots[idx], rows[idx], cols[idx]), dtype=bool)  # type: ignore[attr-defined]
            return ok

        return BatchTest(many)
    return lambda rot, row, col: all(t(rot, row, col) for t in tests)


class RulePipeline:
    """An ordered list of rules; `specs()` is the list a model's metadata stores (pg_policy.decision.rules.registry
    builds a pipeline from one)."""

    def __init__(self, rules: Sequence[Rule]) -> None:
        names = [r.name for r in rules]
        if len(set(names)) != len(names):
            raise ValueError(f"a rule may appear once in the rule list, got {names}")
        self.rules = list(rules)
        self._before: RuleContext | None = None
        # seconds spent by the last apply(), per rule name (its adjust and its candidate tests) and "rerank" (the
        # walk over the candidates itself): what `pushgrasp bench` reports per rule
        self.timings: dict[str, float] = {}

    def specs(self) -> list[str]:
        return [r.spec() for r in self.rules]

    def __getitem__(self, name: str) -> Rule:
        for r in self.rules:
            if r.name == name:
                return r
        raise KeyError(name)

    def __contains__(self, name: object) -> bool:
        return any(r.name == name for r in self.rules)

    def reset(self) -> None:
        self._before = None
        for r in self.rules:
            r.reset()

    def observe(self, last: Any, ctx: RuleContext) -> None:
        """Tell every rule what the previous decision `last` did, `ctx` being the observation after it (nothing on a
        trial's first decision)."""
        if last is not None and self._before is not None:
            for r in self.rules:
                r.observe(last, self._before, ctx)
        self._before = ctx

    def apply(self, q: dict[str, np.ndarray], ctx: RuleContext) -> RuleOutcome:
        """The maps {"grasp": (R, H, W), "push": (R, H, W)} after every rule, for the decision in `ctx`."""
        out, shown, push_instead, note = {}, {}, False, ""
        rejected, vetoed = {"grasp": 0, "push": 0}, {"grasp": False, "push": False}
        self.timings = timings = {r.name: 0.0 for r in self.rules} | {"rerank": 0.0}
        for primitive in ("grasp", "push"):
            rules = [r for r in self.rules if r.primitive == primitive]
            m = q[primitive]
            for r in rules:
                if r.kind == "filter":
                    m = _timed_adjust(r, m, ctx, timings)
            shown[primitive] = m
            for r in rules:
                if r.kind != "filter":
                    m = _timed_adjust(r, m, ctx, timings)
            tested = []
            for r in rules:
                start = time.perf_counter()
                t = r.candidate_test(ctx)
                timings[r.name] += time.perf_counter() - start
                if t is not None:
                    tested.append((r, _timed_test(r.name, t, timings)))
            if tested:
                region = ctx.region(primitive)
                start, inside = time.perf_counter(), sum(timings[r.name] for r, _ in tested)
                m, rank = rerank(m, region, conjunction([t for _, t in tested]), max(r.top_k for r, _ in tested))
                timings["rerank"] += time.perf_counter() - start - (sum(timings[r.name] for r, _ in tested) - inside)
                rejected[primitive] = rank or 0
                vetoed[primitive] = rank is None and bool((region[None] & np.isfinite(m)).any())
                vetoers = [r for r, _ in tested if r.vetoes_grasp]
                if primitive == "grasp" and vetoed[primitive] and vetoers:
                    push_instead, note = True, vetoers[0].veto_note
            out[primitive] = m
        return RuleOutcome(out, shown, push_instead, note, rejected, vetoed)

    def forced_grasp(self, q: np.ndarray, ctx: RuleContext) -> tuple[np.ndarray, int | None]:
        """(Q_g re-ranked, the fallback level that passed) for a grasp the push budget forces while no candidate of
        the (R, H, W) map `q` (as `apply` left it) passes the grasp rules' tests: level i asks every grasp rule's
        i-th fallback test (pg_policy.decision.rules.rule.Rule.fallback_tests; its last one past its end, its
        candidate_test when it has none) of the best FORCED_TOP_K candidates of the grasp region, and the first
        level with a passing candidate re-ranks the map as `apply` does. (q unchanged, None) when no level passes
        or no rule has a fallback."""
        per_rule = [(fb, None if fb else r.candidate_test(ctx))  # a rule's own test only where it has no fallback
                    for r in self.rules if r.primitive == "grasp" for fb in [r.fallback_tests(ctx)]]
        for level in range(max((len(fb) for fb, _ in per_rule), default=0)):
            tests = [fb[min(level, len(fb) - 1)] if fb else ct for fb, ct in per_rule]
            tests = [t for t in tests if t is not None]
            m, rank = rerank(q, ctx.grasp_region, conjunction(tests), FORCED_TOP_K)
            if rank is not None:
                return m, level
        return q, None


def _timed_adjust(rule: Rule, m: np.ndarray, ctx: RuleContext, timings: dict[str, float]) -> np.ndarray:
    start = time.perf_counter()
    m = rule.adjust(m, ctx)
    timings[rule.name] += time.perf_counter() - start
    return m


def _timed_test(name: str, test: CandidateTest, timings: dict[str, float]) -> CandidateTest:
    """`test` (a BatchTest stays one) adding the seconds it runs to timings[name]."""
    if isinstance(test, BatchTest):
        many = test.many

        def timed_many(rots: np.ndarray, rows: np.ndarray, cols: np.ndarray) -> np.ndarray:
            start = time.perf_counter()
            try:
                return many(rots, rows, cols)
            finally:
                timings[name] += time.perf_counter() - start

        return BatchTest(timed_many)

    def timed(rot: int, row: int, col: int) -> bool:
        start = time.perf_counter()
        try:
            return test(rot, row, col)
        finally:
            timings[name] += time.perf_counter() - start

    return timed
