"""Policies by name: the built-in ones, third-party plugins, and exported models on disk.

Built-ins: ``random`` (pg_policy.policies.random_policy), ``heuristic`` (pg_policy.policies.heuristic),
``grasp-only`` (pg_policy.policies.grasp_only) and ``learned`` (pg_policy.policies.learned). Plugins: every entry
point of the group ``pushgrasp.policies`` of an installed distribution names a factory (a class or function taking
pg_policy.policies.policy.PolicyOptions and returning a Policy); `pushgrasp eval --policy NAME`, `pushgrasp infer
--policy NAME`, the policy node's ``~policy`` and `pushgrasp policies` find them (docs/PLUGINS.md). Learned policies
are also made from a model path given as the name (see `make_policy`).
"""

from __future__ import annotations

import importlib
from dataclasses import dataclass, replace
from importlib.metadata import entry_points
from pathlib import Path
from typing import Any

from pg_core.resources import shipped_models
from pg_policy.policies.model_files import GRASP_FILE, PUSH_FILE
from pg_policy.policies.policy import Policy, PolicyOptions

ENTRY_POINT_GROUP = "pushgrasp.policies"
BUILTIN = {
    "random": "pg_policy.policies.random_policy:RandomPolicy",
    "heuristic": "pg_policy.policies.heuristic:HeuristicPolicy",
    "grasp-only": "pg_policy.policies.grasp_only:GraspOnlyPolicy",
    "learned": "pg_policy.policies.learned:LearnedPolicy",
}
NEEDS_MODEL = ("grasp-only", "learned")


class UnknownPolicyError(ValueError):
    """A policy name that is neither registered nor a model path; the message lists the registry."""


@dataclass(frozen=True)
class PolicyEntry:
    """name: what --policy takes; target: "module:attribute" of the factory; origin: "built-in" or the plugin's
    distribution."""

    name: str
    target: str
    origin: str

    def load(self) -> Any:
        """The factory; ImportError/AttributeError with the entry named when the target cannot be loaded."""
        module, _, attr = self.target.partition(":")
        try:
            obj: Any = importlib.import_module(module)
            for part in attr.split("."):
                obj = getattr(obj, part)
        except (ImportError, AttributeError) as exc:
            raise type(exc)(f"policy {self.name!r} ({self.origin}): cannot load {self.target}: {exc}") from exc
        return obj


def policies() -> dict[str, PolicyEntry]:
    """Every known policy by name: the built-ins, then the installed plugins (a plugin may not take a built-in's
    name; it is listed under "<distribution>:<name>" then)."""
    out = {name: PolicyEntry(name, target, "built-in") for name, target in BUILTIN.items()}
    for ep in entry_points(group=ENTRY_POINT_GROUP):
        dist = ep.dist.name if ep.dist is not None else "unknown distribution"
        name = ep.name if ep.name not in out else f"{dist}:{ep.name}"
        out[name] = PolicyEntry(name, ep.value, dist)
    return out


def _construct(entry: PolicyEntry, opts: PolicyOptions) -> Policy:
    policy = entry.load()(opts)
    if not isinstance(policy, Policy):
        raise TypeError(f"policy {entry.name!r} ({entry.origin}): {entry.target} returned {type(policy).__name__}, "
                        "which lacks the Policy protocol (name, reset, act, q_maps: docs/PLUGINS.md)")
    return policy


def make_policy(name_or_path: str, opts: PolicyOptions | None = None) -> Policy:
    """A policy by registered name (built-in or plugin), or `learned` / `grasp-only` from a model path given as the
    name (a directory with grasp.pt and push.pt -> learned, with grasp.pt only or a single file -> grasp-only), or
    from the name of a folder of the shipped models (pg_core.resources.shipped_models(), e.g. "lite"; a path that
    exists wins).

    Raises UnknownPolicyError (a ValueError) listing the policies, FileNotFoundError for missing model files.
    """
    opts = opts or PolicyOptions()
    known = policies()
    if name_or_path in known:
        if name_or_path in NEEDS_MODEL and not opts.models:
            raise FileNotFoundError(f"policy {name_or_path!r} needs a model: --model DIR (with {GRASP_FILE}"
                                    f"{', ' + PUSH_FILE if name_or_path == 'learned' else ''}) or model file(s)")
        return _construct(known[name_or_path], opts)
    path = Path(name_or_path).expanduser()
    if not path.exists() and (shipped_models() / name_or_path).is_dir():
        path = shipped_models() / name_or_path  # a shipped model by folder name, e.g. "lite"
    if path.is_dir() or path.suffix == ".pt" or path.exists():
        kind = "learned" if (path.is_dir() and (path / PUSH_FILE).is_file()) else "grasp-only"
        if not path.exists():
            raise FileNotFoundError(f"model file not found: {path}")
        return _construct(known[kind], replace(opts, models=(path, *opts.models)))
    raise UnknownPolicyError(f"unknown policy {name_or_path!r}: not a registered policy ({', '.join(known)}) nor a "
                             "model file or directory")
