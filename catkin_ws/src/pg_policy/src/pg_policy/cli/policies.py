"""`pushgrasp policies`: the policies `--policy` accepts (built-ins and installed plugins), the shipped models, and
the test-time rules a learned model's rule list may name."""

from __future__ import annotations

import argparse


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("policies", help="list the policies (built-in and plugins), shipped models and rules",
                       description="Plugins register through the Python entry-point groups `pushgrasp.policies` "
                                   "and `pushgrasp.rules` (docs/PLUGINS.md).")
    p.set_defaults(run=_run)


def _run(args: argparse.Namespace) -> int:
    from pg_core.resources import shipped_models
    from pg_policy.decision.rules.registry import ENTRY_POINT_GROUP as RULE_GROUP
    from pg_policy.decision.rules.registry import RulePluginError, rule_entries
    from pg_policy.policies.registry import ENTRY_POINT_GROUP, policies

    print(f"policies (built-in, and plugins of the entry-point group {ENTRY_POINT_GROUP}):")
    for name, entry in policies().items():
        print(f"  {name:<20} {entry.origin:<20} {entry.target}")
    shipped = shipped_models()
    models = sorted(p.name for p in shipped.iterdir() if (p / "grasp.pt").is_file())
    print(f"shipped models (--policy NAME; {shipped}):")
    for name in models:
        print(f"  {name}")
    print(f"test-time rules (a model's `rules` list, or --rules name[:arg],...; built-in, and plugins of the "
          f"entry-point group {RULE_GROUP}):")
    rows = []
    for name, entry in rule_entries().items():
        try:
            cls = entry.cls
        except RulePluginError as exc:  # listed with the reason, so that the other rules still show
            rows.append((1000, f"  {name:<20} {exc}"))
            continue
        flag = cls.option.flag if cls.option is not None else "-"
        origin = "" if entry.origin == "built-in" else f" {entry.origin}"
        rows.append((cls.order, f"  {name:<20} {cls.primitive:<6} {cls.kind:<10} {flag}{origin}".rstrip()))
    for _, row in sorted(rows, key=lambda r: r[0]):
        print(row)
    return 0
