"""Test-time rules by name, and the rule list of a model.

Every module of the package pg_policy.decision.rules that defines a subclass of Rule (pg_policy.decision.rules.rule)
with a `name` contributes that rule: adding a rule is adding a module (and its test). Installed distributions add
rules through the entry-point group ``pushgrasp.rules`` (ENTRY_POINT_GROUP): each entry point, called like the rule,
names its Rule subclass ("module:Class"); it is loaded when first used and may not take a built-in rule's name
(docs/PLUGINS.md, "Writing a rule"). A rule list is a sequence of
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
from dataclasses import dataclass, field
from functools import cache, cached_property
from importlib.metadata import entry_points
from typing import Any

from pg_core.geometry import Geometry
from pg_policy.decision.rules.pipeline import MAPS, RulePipeline
from pg_policy.decision.rules.rule import Rule, kind_named

PACKAGE = "pg_policy.decision.rules"
NOT_RULES = ("rule", "pipeline", "registry")  # the package's own machinery
ENTRY_POINT_GROUP = "pushgrasp.rules"  # third-party rules: entry point name = rule name, value = "module:RuleClass"
BUILT_IN = "built-in"
FAILED_GRASP_RADIUS_M = 0.01  # the failed-grasp memory every learned policy had before rule lists existed


class RulePluginError(ValueError):
    """A rule plug-in that cannot be used: its entry point does not load, names no valid Rule subclass, or takes a
    name already taken. The message names the entry point and its distribution."""


@dataclass(frozen=True)
class RuleEntry:
    """A rule by name: target: "module:Class"; origin: "built-in" or the plug-in's distribution; `cls` loads and
    checks a plug-in's class when first asked for (RulePluginError naming the entry point when it cannot)."""

    name: str
    target: str
    origin: str
    loader: Any = field(default=None, repr=False, compare=False)  # the class itself, or the entry point to load

    @cached_property
    def cls(self) -> type[Rule]:
        if isinstance(self.loader, type):
            return self.loader
        try:
            obj = self.loader.load()
        except Exception as exc:  # an import error, a missing attribute, or the module's own failure
            raise RulePluginError(f"{self.where()}: cannot load {self.target}: {type(exc).__name__}: {exc}") from exc
        check_plugin_rule(obj, self)
        return obj

    def where(self) -> str:
        """The plug-in's description in errors: entry point, group and distribution."""
        return f"rule plug-in {self.name!r} (entry point {self.name} = {self.target} of the distribution " \
               f"{self.origin}, group {ENTRY_POINT_GROUP})"


def check_plugin_rule(obj: Any, entry: RuleEntry) -> None:
    """RulePluginError naming the entry point unless `obj` is a usable Rule subclass for it: called like the entry
    point, on a known map and of a known kind, without a user option (plug-in rules are switched by rule lists)."""
    where = entry.where()
    if not (isinstance(obj, type) and issubclass(obj, Rule)):
        raise RulePluginError(f"{where}: {entry.target} is {obj!r}, not a subclass of "
                              "pg_policy.decision.rules.rule.Rule")
    if obj.name != entry.name:
        raise RulePluginError(f"{where}: the class's `name` is {obj.name!r}; it must equal the entry point's name "
                              f"{entry.name!r} (rule lists name the rule by it)")
    if obj.primitive not in MAPS:
        raise RulePluginError(f"{where}: `primitive` must be one of {', '.join(MAPS)}, got {obj.primitive!r}")
    try:
        kind_named(obj.kind)
    except ValueError as exc:
        raise RulePluginError(f"{where}: {exc}") from None
    if obj.option is not None:
        raise RulePluginError(f"{where}: declares the option {obj.option.name!r}; options are declared by built-in "
                              "rules only: switch a plug-in rule with the rule list (--rules, the model's `rules`)")


@cache
def builtin_rule_classes() -> dict[str, type[Rule]]:
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


@cache
def rule_entries() -> dict[str, RuleEntry]:
    """Every rule by name: the built-ins, then the plug-ins of ENTRY_POINT_GROUP by name (not loaded yet).
    RulePluginError naming both for a plug-in called like a built-in rule or like another plug-in."""
    out = {name: RuleEntry(name, f"{cls.__module__}:{cls.__qualname__}", BUILT_IN, cls)
           for name, cls in builtin_rule_classes().items()}
    for ep in sorted(entry_points(group=ENTRY_POINT_GROUP), key=lambda e: e.name):
        dist = ep.dist.name if ep.dist is not None else "unknown distribution"
        entry = RuleEntry(ep.name, ep.value, dist, ep)
        if ep.name in out:
            taken = out[ep.name]
            by = "a built-in rule" if taken.origin == BUILT_IN else f"the rule plug-in of {taken.origin}"
            raise RulePluginError(f"{entry.where()}: the name {ep.name!r} is taken by {by} ({taken.target}); "
                                  "rename the plug-in's entry point and its rule's `name`, or uninstall " + dist)
        out[ep.name] = entry
    return out


def rule_classes() -> dict[str, type[Rule]]:
    """{name: Rule subclass} of every rule, built-ins and plug-ins (each loaded), sorted by the rules' `order`.
    RulePluginError for a plug-in that cannot be loaded."""
    classes = {name: entry.cls for name, entry in rule_entries().items()}
    return dict(sorted(classes.items(), key=lambda kv: kv[1].order))


def rule_class(name: str) -> type[Rule]:
    """The Rule subclass of `name` or of a rule list entry "name:arg" (a plug-in is loaded now); ValueError for an
    unknown name, RulePluginError for a plug-in that cannot be loaded."""
    return rule_entries()[parse_spec(name)[0]].cls


def reload_rules() -> None:
    """Forget the rules found so far: the next lookup reads the package and the installed plug-ins again (after a
    distribution was installed or removed in this process)."""
    builtin_rule_classes.cache_clear()
    rule_entries.cache_clear()


def parse_spec(spec: str) -> tuple[str, str | None]:
    """("name", "arg" or None) of a rule list entry; ValueError for an unknown name or a malformed entry."""
    if not isinstance(spec, str) or not spec.strip():
        raise ValueError(f"a rule list entry is 'name' or 'name:arg', got {spec!r}")
    name, _, arg = spec.strip().partition(":")
    if name not in rule_entries():
        raise ValueError(f"unknown rule {name!r} (known: {', '.join(rule_entries())})")
    return name, (arg if arg else None)


def make_rule(spec: str, geometry: Geometry) -> Rule:
    """The rule of one rule list entry ("name" or "name:arg"); ValueError for a bad entry or argument,
    RulePluginError (a ValueError) for a plug-in that cannot be loaded."""
    name, arg = parse_spec(spec)
    return rule_entries()[name].cls.from_arg(geometry, arg)


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
    out = [s for s in specs if parse_spec(s)[0] != name]
    if spec is None:
        return out
    for i, s in enumerate(specs):
        if parse_spec(s)[0] == name:
            return [*specs[:i], spec, *specs[i + 1:]]
    order = rule_class(name).order
    at = next((i for i, s in enumerate(out) if rule_class(s).order > order), len(out))
    return [*out[:at], spec, *out[at:]]
