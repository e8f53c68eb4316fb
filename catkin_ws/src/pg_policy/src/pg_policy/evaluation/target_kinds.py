"""Results per kind of target (thin, rod, rolling, concave, small, wide, blob, named, block) for the generated
families of catalogue objects (novel-N, novel-packed-N, mixed-N, train-...).

A trial's target is object 0 of its generated scene, which depends only on (scene, seed): the kind is recomputed from
them (pg_sim.world.scene_families, no physics), so records written before need nothing extra. Scenes that are not
catalogue families (random-N, dense-N, fixed scenes) have no kind rows.

``python -m pg_policy.evaluation.target_kinds RUN [...]`` prints the table of saved runs: RUN is a results.json or
an output folder of `pushgrasp eval` (its results.json, or the trials.jsonl of a run still going or stopped).
``--pooled NAME=RUN[,RUN...] [...]`` pools the scenes of each named set of runs and prints one table, a row per kind
and a column per name (a RUN may also be a folder of output folders, e.g. results/novel/lite).
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from functools import lru_cache
from pathlib import Path

from pg_policy.evaluation.saved_runs import load_tree, load_trials
from pg_policy.evaluation.trials import Stat, TrialRecord, scene_metrics
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


def pooled_by_kind(trials: Sequence[TrialRecord]) -> dict[str, dict[str, Stat]]:
    """{kind: C, GS, MN, ...} over the catalogue-family trials of all scenes together, kinds sorted."""
    groups: dict[str, list[TrialRecord]] = {}
    for t in trials:
        kind = target_kind_of(t.scene, int(t.seed))
        if kind is not None:
            groups.setdefault(kind, []).append(t)
    return {kind: scene_metrics(groups[kind]) for kind in sorted(groups)}


def pooled_lines(named: Sequence[tuple[str, Sequence[TrialRecord]]]) -> list[str]:
    """Markdown table: a row per target kind, a column per (name, trials) with n, C and GS (%) pooled over its
    scenes; a kind a set has no trial of shows "-". Empty list when no set has a catalogue-family trial."""
    from pg_policy.evaluation.report import fmt

    tables = [(name, pooled_by_kind(trials)) for name, trials in named]
    kinds = sorted({k for _, table in tables for k in table})
    if not kinds:
        return []
    lines = ["| target kind | " + " | ".join(f"{name}: n, C / GS (%)" for name, _ in tables) + " |",
             "|---|" + "---|" * len(tables)]
    for kind in kinds:
        cells = [f"{m['C'].n}, {fmt(m['C'], 100)} / {fmt(m['GS'], 100)}" if (m := table.get(kind)) else "-"
                 for _, table in tables]
        lines.append(f"| {kind} | " + " | ".join(cells) + " |")
    return lines + [""]


def _named(arg: str) -> tuple[str, list[Path]]:
    """('NAME', [RUN, ...]) of a --pooled argument NAME=RUN[,RUN...] (NAME defaults to the first RUN)."""
    name, sep, runs = arg.partition("=")
    if not sep:
        name, runs = arg, arg
    paths = [Path(r) for r in runs.split(",") if r]
    if not name or not paths:
        raise ValueError(f"'{arg}': expected NAME=RUN[,RUN...]")
    return name, paths


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m pg_policy.evaluation.target_kinds",
                                     description="C, GS and MN per kind of target of saved `pushgrasp eval` runs.")
    parser.add_argument("runs", nargs="+", type=Path,
                        help="results.json files or `pushgrasp eval` output folders (a folder without results.json: "
                             "the finished trials of its trials.jsonl)")
    parser.add_argument("--pooled", action="store_true",
                        help="runs are NAME=RUN[,RUN...] (a RUN may be a folder of output folders): one table, a "
                             "row per kind and a column per NAME, the scenes of each NAME pooled")
    args = parser.parse_args(argv)
    from pg_policy.evaluation.report import kind_lines

    if args.pooled:
        try:
            named = [(name, [t for p in paths for t in load_tree(p)])
                     for name, paths in (_named(str(a)) for a in args.runs)]
        except (OSError, ValueError, KeyError) as exc:
            print(f"error: {exc}", file=sys.stderr)
            return 2
        print("\n".join(pooled_lines(named)) or "(no catalogue-family trials)")
        return 0
    for path in args.runs:
        try:
            trials = load_trials(path)
        except (OSError, ValueError, KeyError) as exc:
            print(f"error: {path}: {exc}", file=sys.stderr)
            return 2
        print(f"## {path} ({len(trials)} trials)\n")
        print("\n".join(kind_lines(trials)) or "(no catalogue-family trials)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
