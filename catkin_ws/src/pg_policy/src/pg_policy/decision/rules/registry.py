"""Test-time rules by name, and the rule list of a model.

Every module of the package pg_policy.decision.rules that defines a subclass of Rule (pg_policy.decision.rules.rule)
with a `name` contributes that rule: adding a rule is adding a module (and its test). A rule list is a sequence of
entries "name" or "name:arg" (the argument is the rule's own: a filter spec, a radius in metres, a variant), applied
in order. A model stores its list in the metadata key `rules`; models exported before rule lists existed keep their
decision switches under `thresholds` (grasp_filter, grasp_check, edge_guard, push_landing), which `model_rules`
reads into the equivalent list.
"""

from __future__ import annotations

import importlib
import inspect
import pkgutil
from collections.abc import Mapping, Sequence
from functools import cache
from typing import Any

from pg_core.geometry import Geometry
from pg_policy.decision.rules.pipeline import RulePipeline
from pg_policy.decision.rules.rule import Rule

PACKAGE = "pg_policy.decision.rules"
NOT_RULES = ("rule", "pipeline", "registry")  # the package's own machinery
FAILED_GRASP_RADIUS_M = 0.01  # the failed-grasp memory every learned policy had before rule lists existed


@cache
def rule_classes() -> dict[str, type[Rule]]:
    """{name: Rule subclass} of every rule module in the package, sorted by the rules' `order`."""
    package = importlib.import_module(PACKAGE)
    found: dict[str, type[Rule]] = {}
    for info in pkgutil.iter_modules(package.__path__):
        if info.name in NOT_RULES:
            continue
        module = importlib.import_module(f"{PACKAGE}.{info.name}")
        for _, cls in inspect.getmembers(module, inspect.isclass):
            if issubclass(cls, Rule) and cls is not Rule and cls.__module__ == module.__name__ and cls.name:
                if cls.name in found:
                    raise RuntimeError(f"two rules are called {cls.name!r}: {found[cls.name]} and {cls}")
                found[cls.name] = cls
    return dict(sorted(found.items(), key=lambda kv: kv[1].order))


def parse_spec(spec: str) -> tuple[str, str | None]:
    """("name", "arg" or None) of a rule list entry; ValueError for an unknown name or a malformed entry."""
    if not isinstance(spec, str) or not spec.strip():
        raise ValueError(f"a rule list entry is 'name' or 'name:arg', got {spec!r}")
    name, _, arg = spec.strip().partition(":")
    if name not in rule_classes():
        raise ValueError(f"unknown rule {name!r} (known: {', '.join(rule_classes())})")
    return name, (arg if arg else None)


def make_rule(spec: str, geometry: Geometry) -> Rule:
    """The rule of one rule list entry ("name" or "name:arg"); ValueError for a bad entry or argument."""
    name, arg = parse_spec(spec)
    return rule_classes()[name].from_arg(geometry, arg)


def make_pipeline(specs: Sequence[str], geometry: Geometry) -> RulePipeline:
    """The pipeline of a rule list, in its order; ValueError for a bad entry or a rule named twice."""
    return RulePipeline([make_rule(s, geometry) for s in specs])


def legacy_rules(thresholds: Mapping[str, Any]) -> list[str]:
    """The rule list equivalent to the decision switches of a model exported before rule lists existed."""
    specs = []
    if (spec := thresholds.get("grasp_filter")) not in (None, "", "none"):
        specs.append(f"grasp_filter:{spec}")
    specs.append(f"failed_grasps:{FAILED_GRASP_RADIUS_M:g}")
    if (check := thresholds.get("grasp_check")) not in (None, "none"):
        specs.append(f"grasp_check:{check}")
    if thresholds.get("push_landing"):
        specs.append("push_landing")
    if thresholds.get("edge_guard"):
        specs.append("edge_guard")
    return specs


def model_rules(metadata: Mapping[str, Any]) -> list[str]:
    """The rule list of a model's (grasp net's) metadata: its `rules`, else the legacy `thresholds` switches.
    ValueError when `rules` is not a list of strings or names an unknown rule."""
    rules = metadata.get("rules")
    if rules is None:
        thresholds = metadata.get("thresholds")
        return legacy_rules(thresholds if isinstance(thresholds, Mapping) else {})
    if not isinstance(rules, list) or not all(isinstance(r, str) for r in rules):
        raise ValueError(f"model metadata 'rules' must be a list of 'name' or 'name:arg' strings, got {rules!r}")
    for r in rules:
        parse_spec(r)
    return list(rules)


def with_switch(specs: Sequence[str], name: str, spec: str | None) -> list[str]:
    """`specs` with rule `name` replaced by `spec` (kept in place), inserted at its `order` when absent, or removed
    when `spec` is None."""
    classes = rule_classes()
    out = [s for s in specs if parse_spec(s)[0] != name]
    if spec is None:
        return out
    for i, s in enumerate(specs):
        if parse_spec(s)[0] == name:
            return [*specs[:i], spec, *specs[i + 1:]]
    order = classes[name].order
    at = next((i for i, s in enumerate(out) if classes[parse_spec(s)[0]].order > order), len(out))
    return [*out[:at], spec, *out[at:]]
