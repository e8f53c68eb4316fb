"""Running one test-time rule alone on a Q map, the way the rule pipeline runs it (shared by the rule tests)."""

from __future__ import annotations

import numpy as np

from pg_core.heightmap import Heightmap
from pg_policy.decision.rules.pipeline import RuleOutcome, RulePipeline
from pg_policy.decision.rules.rule import Rule, RuleContext


def context(hm: Heightmap, target: np.ndarray, region: np.ndarray | None = None,
            visible: bool | None = None) -> RuleContext:
    """A context whose grasp and push regions are both `region` (default: the target mask)."""
    region = target if region is None else region
    return RuleContext(hm, target, bool(target.any()) if visible is None else visible, region, region)


def apply_rule(rule: Rule, q: np.ndarray, hm: Heightmap, target: np.ndarray,
               region: np.ndarray | None = None) -> tuple[np.ndarray, RuleOutcome]:
    """(the rule's map after a one-rule pipeline, the outcome) for map `q` of the rule's primitive."""
    other = "push" if rule.primitive == "grasp" else "grasp"
    res = RulePipeline([rule]).apply({rule.primitive: q, other: np.zeros_like(q)}, context(hm, target, region))
    return res.q[rule.primitive], res
