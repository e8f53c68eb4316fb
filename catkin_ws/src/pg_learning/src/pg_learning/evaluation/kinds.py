"""Results per kind of target (thin, rod, rolling, concave, small, wide, blob, named, block) for the generated
families of catalogue objects (novel-N, novel-packed-N, mixed-N, train-...).

A trial's target is object 0 of its generated scene, which depends only on (scene, seed): the kind is recomputed from
them (pg_sim.world.scene_families, no physics), so records written before need nothing extra. Scenes that are not
catalogue families (random-N, dense-N, fixed scenes) have no kind rows.

The tables of saved runs on the command line: `pushgrasp kinds` (pg_learning.cli.kinds). results.md of `pushgrasp
eval` ends with the per-scene table (`kind_lines`, pg_learning.evaluation.report).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from functools import lru_cache

from pg_policy.target_loop.metrics import Stat, fmt, scene_metrics
from pg_policy.target_loop.records import TrialRecord
from pg_sim.world.arrangements import arrangement_of
from pg_sim.world.scene_families import FAMILIES, parse_generated, sample_family, target_kind


@lru_cache(maxsize=4096)
def target_kind_of(scene: str, seed: int) -> str | None:
    """The kind of the target of trial (scene, seed), None when the scene is not a catalogue family."""
    parsed = parse_generated(scene)
    if parsed is None or FAMILIES[parsed[0]].split is None:
        return None
    return target_kind(sample_family(scene, seed).target_object.name)


def by_kind(trials: Sequence[TrialRecord]) -> dict[tuple[str, str], dict[str, Stat]]:
    """{(scene, kind): C, GS, MN, ...} over the trials whose scene is a catalogue family, kinds sorted per scene."""
    groups: dict[tuple[str, str], list[TrialRecord]] = {}
    for t in trials:
        kind = target_kind_of(t.scene, int(t.seed))
        if kind is not None:
            groups.setdefault((t.scene, kind), []).append(t)
    return {key: scene_metrics(groups[key]) for key in sorted(groups)}


def arrangement_of_trial(scene: str, seed: int) -> str | None:
    """The arrangement of the target (pg_sim.world.arrangements) of a trial of a hard household family, else None."""
    parsed = parse_generated(scene)
    if parsed is None or not FAMILIES[parsed[0]].arranged:
        return None
    return FAMILIES[parsed[0]].arrangement or arrangement_of(seed)


# grouping name -> (scene, seed) -> group of the trial (None: the trial is in no group)
GROUPINGS: dict[str, Callable[[str, int], str | None]] = {"kind": target_kind_of, "arrangement": arrangement_of_trial}


def pooled_by_kind(trials: Sequence[TrialRecord], by: str = "kind") -> dict[str, dict[str, Stat]]:
    """{group: C, GS, MN, ...} over the trials of all scenes together, groups sorted; ``by`` names a GROUPINGS entry
    (the target's kind, or the arrangement of hard families). Raises KeyError for an unknown grouping."""
    group_of = GROUPINGS[by]
    groups: dict[str, list[TrialRecord]] = {}
    for t in trials:
        kind = group_of(t.scene, int(t.seed))
        if kind is not None:
            groups.setdefault(kind, []).append(t)
    return {kind: scene_metrics(groups[kind]) for kind in sorted(groups)}


def pooled_lines(named: Sequence[tuple[str, Sequence[TrialRecord]]], by: str = "kind") -> list[str]:
    """Markdown table: a row per group (target kind, or arrangement: ``by``), a column per (name, trials) with n, C
    and GS (%) pooled over its scenes; a group a set has no trial of shows "-". Empty list when no trial is in a
    group."""
    tables = [(name, pooled_by_kind(trials, by)) for name, trials in named]
    kinds = sorted({k for _, table in tables for k in table})
    if not kinds:
        return []
    head = "target kind" if by == "kind" else by
    lines = [f"| {head} | " + " | ".join(f"{name}: n, C / GS (%)" for name, _ in tables) + " |",
             "|---|" + "---|" * len(tables)]
    for kind in kinds:
        cells = [f"{m['C'].n}, {fmt(m['C'], 100)} / {fmt(m['GS'], 100)}" if (m := table.get(kind)) else "-"
                 for _, table in tables]
        lines.append(f"| {kind} | " + " | ".join(cells) + " |")
    return lines + [""]


def kind_lines(trials: Sequence[TrialRecord]) -> list[str]:
    """Markdown table of the per-target-kind metrics (empty list when no trial is in a catalogue family)."""
    table = by_kind(trials)
    if not table:
        return []
    lines = ["By kind of target (C and GS in %, MN in pushes; n = trials):", "",
             "| Scene | target kind | n | C (%) | GS (%) | MN |", "|---|---|---|---|---|---|"]
    for (scene, kind), m in table.items():
        lines.append(f"| {scene} | {kind} | {m['C'].n} | {fmt(m['C'], 100)} | {fmt(m['GS'], 100)} | "
                     f"{fmt(m['MN'], 1, 2)} |")
    return lines + [""]
