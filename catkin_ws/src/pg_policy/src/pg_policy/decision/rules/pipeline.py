"""The ordered chain of test-time rules between the learned nets' Q maps and the decision.

For each Q map (grasp, then push) the pipeline applies, in the configured order, the `adjust` of every rule on that
map whose kind shapes the map users see (filters), then the others' (pg_policy.decision.rules.rule.RULE_KINDS), then
re-ranks the map once by the conjunction of the rules' candidate tests (pg_policy.decision.rerank; when no
candidate passes the tests of the "preference" rules with the others, by the others' alone): the
best-valued candidate inside the primitive's region that passes every test takes the map's best value, so the
grasp-or-push decision (masked max vs the threshold) is unchanged by the tests; when none of the best `top_k`
passes, the candidates the map's rules propose (Rule.proposals) are asked in descending value with the same tests,
and when none of those passes either, the map is left as it was and a vetoing grasp rule asks the policy to push
instead. When the policy must
grasp all the same (its push budget is spent), `forced_grasp` re-ranks Q_g by the rules' weaker fallback tests.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterable, Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass
from typing import Any

import numpy as np

from pg_policy.decision.rerank import rerank, rerank_among
from pg_policy.decision.rules.rule import BatchTest, CandidateTest, Rule, RuleContext

FORCED_TOP_K = 1000  # candidates examined per fallback level of a forced grasp
MAPS = ("grasp", "push")  # the Q maps, in the order the pipeline runs them


@dataclass(frozen=True)
class RuleOutcome:
    """q: the adjusted maps {"grasp", "push"} the decision uses; shown: the maps after the "filter" rules only (what
    the policy shows users as its Q maps); push_instead: a vetoing grasp rule found no passing grasp; note: why;
    rejected: per map, the candidates ranked above the one that passed every test (0: the best passed, or no tests);
    vetoed: per map, candidate tests ran and no candidate of a non-empty region passed; proposed: per map, the names
    of the rules whose proposals were asked when the chosen candidate is one of those (empty otherwise)."""

    q: dict[str, np.ndarray]
    shown: dict[str, np.ndarray]
    push_instead: bool
    note: str
    rejected: dict[str, int]
    vetoed: dict[str, bool]
    proposed: dict[str, tuple[str, ...]]


@dataclass(frozen=True)
class MapOutcome:
    """One map after its rules (RulePipeline.apply): q, shown, rejected, vetoed and proposed as in RuleOutcome;
    vetoers: the map's rules with a candidate test that ask for a push when it passes no candidate
    (Rule.vetoes_grasp)."""

    q: np.ndarray
    shown: np.ndarray
    rejected: int
    vetoed: bool
    vetoers: list[Rule]
    proposed: tuple[str, ...] = ()


def _any(rotation: int, row: int, col: int) -> bool:
    """The candidate test every candidate passes."""
    return True


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
        for r in rules:
            r.rule_kind()  # ValueError for a kind the pipeline does not know
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
        """The maps {"grasp": (R, H, W), "push": (R, H, W)} after every rule, for the decision in `ctx`. The seconds
        each rule took are in `timings` afterwards."""
        timer = RuleTimer(r.name for r in self.rules)
        self.timings = timer.seconds
        maps = {primitive: self._apply_map(primitive, q[primitive], ctx, timer) for primitive in MAPS}
        grasp = maps["grasp"]
        veto = grasp.vetoers[0] if grasp.vetoed and grasp.vetoers else None
        return RuleOutcome({p: m.q for p, m in maps.items()}, {p: m.shown for p, m in maps.items()},
                           veto is not None, veto.veto_note if veto is not None else "",
                           {p: m.rejected for p, m in maps.items()}, {p: m.vetoed for p, m in maps.items()},
                           {p: m.proposed for p, m in maps.items()})

    def _apply_map(self, primitive: str, q: np.ndarray, ctx: RuleContext, timer: RuleTimer) -> MapOutcome:
        """One map through its rules: the adjusts that shape the shown map (filters), then the others, each in list
        order, then one re-rank by the conjunction of the rules' candidate tests."""
        rules = [TimedRule(r, timer) for r in self.rules if r.primitive == primitive]
        for r in rules:
            if r.rule.rule_kind().shown:
                q = r.adjust(q, ctx)
        shown = q
        for r in rules:
            if not r.rule.rule_kind().shown:
                q = r.adjust(q, ctx)
        tested = [(r.rule, t) for r in rules if (t := r.candidate_test(ctx)) is not None]
        if not tested:
            return MapOutcome(q, shown, 0, False, [])
        region = ctx.region(primitive)
        top_k = max(r.top_k for r, _ in tested)
        hard = [(r, t) for r, t in tested if not r.rule_kind().soft]
        tests = [conjunction([t for _, t in tested])]
        if len(hard) < len(tested):  # no candidate passes the preferences: the checks alone
            tests.append(conjunction([t for _, t in hard]) if hard else _any)

        def first_passing(walk: Callable[[CandidateTest], tuple[np.ndarray, int | None]]) -> tuple[np.ndarray,
                                                                                                  int | None]:
            with timer.charge("rerank", exclusive=True):
                for test in tests:
                    ranked, rank = walk(test)
                    if rank is not None:
                        break
            return ranked, rank

        ranked, rank = first_passing(lambda test: rerank(q, region, test, top_k))
        proposed: tuple[str, ...] = ()
        if rank is None:
            offered = [(r.rule.name, p) for r in rules if (p := r.proposals(ctx)) is not None and len(p[0])]
            if offered:
                candidates = tuple(np.concatenate([p[i] for _, p in offered]) for i in range(3))
                ranked, rank = first_passing(lambda test: rerank_among(q, region, test, candidates))
                proposed = tuple(name for name, _ in offered) if rank is not None else ()
        vetoed = rank is None and bool((region[None] & np.isfinite(ranked)).any())
        return MapOutcome(ranked, shown, rank or 0, vetoed, [r for r, _ in hard if r.vetoes_grasp], proposed)

    def forced_grasp(self, q: np.ndarray, ctx: RuleContext) -> tuple[np.ndarray, int | None]:
        """(Q_g re-ranked, the fallback level that passed) for a grasp the push budget forces while no candidate of
        the (R, H, W) map `q` (as `apply` left it) passes the grasp rules' tests: level i asks every grasp rule's
        i-th fallback test (pg_policy.decision.rules.rule.Rule.fallback_tests; its last one past its end, its
        candidate_test when it has none; a preference rule's candidate_test while a candidate passes it with the
        others) of the best FORCED_TOP_K candidates of the grasp region, and the first
        level with a passing candidate re-ranks the map as `apply` does. (q unchanged, None) when no level passes
        or no rule has a fallback."""
        grasp_rules = [r for r in self.rules if r.primitive == "grasp"]
        per_rule = [(fb, None if fb else r.candidate_test(ctx))  # a rule's own test only where it has no fallback
                    for r in grasp_rules if not r.rule_kind().soft for fb in [r.fallback_tests(ctx)]]
        soft = [t for r in grasp_rules if r.rule_kind().soft and (t := r.candidate_test(ctx)) is not None]
        for level in range(max((len(fb) for fb, _ in per_rule), default=0)):
            tests = [fb[min(level, len(fb) - 1)] if fb else ct for fb, ct in per_rule]
            tests = [t for t in tests if t is not None]
            for with_soft in ([tests + soft, tests] if soft else [tests]):  # the preferences while one passes
                m, rank = rerank(q, ctx.grasp_region, conjunction(with_soft), FORCED_TOP_K)
                if rank is not None:
                    return m, level
        return q, None


class RuleTimer:
    """Seconds per rule name, and "rerank" (the walk over the candidates itself), of one RulePipeline.apply: what
    `pushgrasp bench` reports per rule. The timing stays out of the pipeline's logic: TimedRule charges a rule's
    calls, `charge` is a context manager around any other block."""

    def __init__(self, names: Iterable[str]) -> None:
        self.seconds: dict[str, float] = {name: 0.0 for name in names} | {"rerank": 0.0}
        self._charged = 0.0  # every second charged so far, to any name

    def add(self, name: str, start: float, exclusive: bool = False, charged_before: float = 0.0) -> None:
        """Charge the seconds since `start` (time.perf_counter()) to `name`; exclusive: less what was charged to any
        name since the total was `charged_before` (the blocks timed inside this one)."""
        spent = time.perf_counter() - start
        if exclusive:
            spent -= self._charged - charged_before
        self.seconds[name] += spent
        self._charged += spent

    @contextmanager
    def charge(self, name: str, exclusive: bool = False) -> Iterator[None]:
        """Charge the block's seconds to `name` (exclusive: less the seconds charged inside it to other names)."""
        start, before = time.perf_counter(), self._charged
        try:
            yield
        finally:
            self.add(name, start, exclusive, before)

    def timed(self, name: str, test: CandidateTest) -> CandidateTest:
        """`test` (a BatchTest stays one) charging the seconds of each call to `name`."""
        if isinstance(test, BatchTest):
            many = test.many

            def timed_many(rots: np.ndarray, rows: np.ndarray, cols: np.ndarray) -> np.ndarray:
                start = time.perf_counter()
                try:
                    return many(rots, rows, cols)
                finally:
                    self.add(name, start)

            return BatchTest(timed_many)

        def timed_one(rot: int, row: int, col: int) -> bool:
            start = time.perf_counter()
            try:
                return test(rot, row, col)
            finally:
                self.add(name, start)

        return timed_one


class TimedRule:
    """`rule` for one apply: its adjust, its candidate_test and the tests that returns charge their seconds to the
    timer under the rule's name."""

    def __init__(self, rule: Rule, timer: RuleTimer) -> None:
        self.rule, self.timer = rule, timer

    def adjust(self, q: np.ndarray, ctx: RuleContext) -> np.ndarray:
        with self.timer.charge(self.rule.name):
            return self.rule.adjust(q, ctx)

    def proposals(self, ctx: RuleContext) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
        with self.timer.charge(self.rule.name):
            return self.rule.proposals(ctx)

    def candidate_test(self, ctx: RuleContext) -> CandidateTest | None:
        with self.timer.charge(self.rule.name):
            test = self.rule.candidate_test(ctx)
        return None if test is None else self.timer.timed(self.rule.name, test)
