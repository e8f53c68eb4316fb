"""The one interface of the test-time rules that adjust the learned policy's Q maps before the decision.

A rule acts on one of the two Q maps (`primitive`: "grasp" or "push"; (R, H, W) float arrays over R rotations and the
heightmap's cells) in one of two ways, in the style of grid_map's filter chains and costmap_2d's layers:
- `adjust(q, ctx)`: return a transformed map (a filter, or a memory that suppresses cells with -inf);
- `candidate_test(ctx)`: return a yes/no test of a candidate (rotation, row, col), or None when the rule has nothing
  to say in this context. The pipeline (pg_policy.decision.rules.pipeline) walks the map's best cells inside the
  primitive's region and keeps the first candidate that passes the tests of every rule on that map.
When none of the map's best cells passes, `proposals(ctx)` may offer candidates of its own (geometric ones the nets
rank low), which the pipeline asks in descending value with the same tests.
When the push budget forces a grasp and no candidate passes, `fallback_tests(ctx)` offers weaker tests in turn.
Within a trial, `observe(last, before, after)` tells a rule what the previous action did (its decision and the
contexts before and after it); `reset()` starts a new trial. A grasp rule with `vetoes_grasp` asks the policy to push
instead when no grasp candidate passes (within the push budget).

A rule's `kind` ("filter", "memory", "check", "preference", "override": RULE_KINDS) says how the pipeline treats it:
a filter's map is the one users see (it runs first on its map), the others shape only the map the decision reads; a
preference's test counts only while some candidate passes it with the checks; an override raises candidates of its
own above the map's best value, where the re-rank asks them first.

Rules are created by name from a model's metadata or the policy options (pg_policy.decision.rules.registry): each
module of this package that defines a Rule subclass with a `name` is one rule, and so is each entry point of the group
`pushgrasp.rules` of an installed distribution (docs/PLUGINS.md, "Writing a rule").
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from pg_core.geometry import Geometry
from pg_core.heightmap import TOP_K, Heightmap
from pg_policy.decision.option import PolicyOption

CandidateTest = Callable[[int, int, int], bool]  # (rotation, row, col) -> allowed


class BatchTest:
    """A candidate test that also answers for many candidates at once: `many(rotations, rows, cols)` takes (K,) int
    arrays and returns a (K,) bool array; calling it with one candidate asks `many` about that one. The re-rank
    (pg_policy.decision.rerank) asks a BatchTest about candidates in growing batches instead of one by one."""

    def __init__(self, many: Callable[[np.ndarray, np.ndarray, np.ndarray], np.ndarray]) -> None:
        self.many = many

    def __call__(self, rotation: int, row: int, col: int) -> bool:
        return bool(self.many(np.array([rotation]), np.array([row]), np.array([col]))[0])


@dataclass(frozen=True)
class RuleContext:
    """What a rule may look at for one decision.

    heightmap: the observation (pg_core.heightmap; `world` metres); target: (H, W) bool target mask when `visible`,
    else every object cell (the goal-agnostic fallback); grasp_region / push_region: (H, W) bool cells where the
    decision looks for the grasp / the start of the push (pg_policy.decision.decision.grasp_region, push_region).
    """

    heightmap: Heightmap
    target: np.ndarray
    visible: bool
    grasp_region: np.ndarray
    push_region: np.ndarray

    def region(self, primitive: str) -> np.ndarray:
        return self.grasp_region if primitive == "grasp" else self.push_region


@dataclass(frozen=True)
class RuleKind:
    """How the pipeline treats the rules of one kind. shown: the rule's `adjust` shapes the map users see (the
    policy's q_maps), so it runs on its map before the rules that shape only the decision's map; reach: the default
    of Rule.reach (0: `adjust` reads no other cell than the one it writes; None: unknown); soft: the rule's
    candidate test is dropped when no candidate passes it together with the other rules' (a preference, never a
    veto)."""

    name: str
    shown: bool
    reach: int | None
    help: str
    soft: bool = False


RULE_KINDS: dict[str, RuleKind] = {k.name: k for k in (
    RuleKind("filter", True, None, "reshapes the map, and the map users see"),
    RuleKind("memory", False, 0, "suppresses cells within a trial"),
    RuleKind("check", False, 0, "a yes/no test of candidates"),
    RuleKind("preference", False, 0, "a yes/no test of candidates, dropped when no candidate passes it", soft=True),
    RuleKind("override", False, 0, "raises candidates of its own above the map's best value (they face the tests)"),
)}


def kind_named(name: str) -> RuleKind:
    """The RuleKind called `name`; ValueError listing the kinds for another name."""
    try:
        return RULE_KINDS[name]
    except KeyError:
        raise ValueError(f"unknown rule kind {name!r} (known: {', '.join(RULE_KINDS)})") from None


class Rule:
    """Base of every test-time rule (module docstring). Subclasses set `name`, `primitive` and `kind` and override
    what they use; `from_arg` builds the rule from its metadata argument (the text after "name:" in the rule list,
    None when absent) and raises ValueError naming the accepted forms for a bad one."""

    name: ClassVar[str] = ""
    primitive: ClassVar[str] = "grasp"  # the Q map the rule acts on: "grasp" or "push"
    kind: ClassVar[str] = "check"  # a RULE_KINDS key: "filter" shapes the map users see (q_maps); "memory"; "check"
    vetoes_grasp: ClassVar[bool] = False  # no passing grasp candidate asks the policy to push instead
    veto_note: ClassVar[str] = ""  # the policy's last_note when this rule's veto makes it push
    option: ClassVar[PolicyOption | None] = None  # the user option that switches the rule (None: only rule lists)
    order: ClassVar[int] = 100  # where an option that switches the rule on inserts it into a model's rule list
    top_k: int = TOP_K  # candidates examined per decision by candidate_test (pg_core.heightmap.TOP_K)

    @classmethod
    def from_arg(cls, geometry: Geometry, arg: str | None) -> Rule:
        if arg is not None:
            raise ValueError(f"rule {cls.name!r} takes no argument, got {arg!r}")
        return cls(geometry)  # type: ignore[call-arg]

    def rule_kind(self) -> RuleKind:
        """How the pipeline treats this rule (RULE_KINDS[kind]); ValueError for an unknown kind."""
        return kind_named(self.kind)

    def arg(self) -> str | None:
        """The argument that `from_arg` turns back into this rule (None: no argument)."""
        return None

    def spec(self) -> str:
        """The rule's entry in a model's rule list: "name" or "name:arg"."""
        a = self.arg()
        return self.name if a is None else f"{self.name}:{a}"

    def reset(self) -> None:
        """Start a new trial: forget what earlier actions did."""

    def observe(self, last: Any, before: RuleContext, after: RuleContext) -> None:
        """The previous decision `last` (pg_policy.decision.decision.Decision) was executed in `before`; `after` is
        the observation the next decision is taken on. Called only when the trial goes on (a grasp asked about here
        missed the target)."""

    def adjust(self, q: np.ndarray, ctx: RuleContext) -> np.ndarray:
        """The (R, H, W) map after this rule (default: unchanged; may return `q` itself)."""
        return q

    def candidate_test(self, ctx: RuleContext) -> CandidateTest | None:
        """A yes/no test of a candidate (rotation, row, col) in this context, or None (no opinion)."""
        return None

    def proposals(self, ctx: RuleContext) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
        """Candidates (rotations, rows, cols: (K,) int arrays) to ask the map's tests about when none of its best
        `top_k` cells passes them (pg_policy.decision.rules.pipeline); None (the default): no proposals."""
        return None

    def fallback_tests(self, ctx: RuleContext) -> list[CandidateTest]:
        """Weaker candidate tests, strongest first, for a grasp that the push budget forces while the grasp map's
        tests pass no candidate (pg_policy.decision.rules.pipeline.RulePipeline.forced_grasp); [] (the default):
        `candidate_test` applies unchanged."""
        return []

    def reach(self) -> int | None:
        """How far (cells) from a cell `adjust` reads the map to compute that cell's value: 0 for rules that do not
        reshape the map, None when unknown (then a windowed Q map gets a generous margin). Default: the kind's."""
        return self.rule_kind().reach


def parse_metres(rule: str, arg: str, what: str) -> float:
    """A distance in metres (>= 0) from the argument of `rule`; ValueError naming the rule and `what` the distance is
    (e.g. "radius") for a non-number or a negative one."""
    try:
        value = float(arg)
    except ValueError:
        raise ValueError(f"rule {rule!r}: the argument is the {what} in metres, got {arg!r}") from None
    if not value >= 0:
        raise ValueError(f"rule {rule!r}: the {what} must be >= 0 m, got {arg!r}")
    return value
