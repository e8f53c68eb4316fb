"""Results per kind of target (thin, rod, rolling, concave, small, wide, blob, named, block) for the generated
families of catalogue objects (novel-N, novel-packed-N, mixed-N, train-...).

A trial's target is object 0 of its generated scene, which depends only on (scene, seed): the kind is recomputed from
them (pg_sim.world.scene_families, no physics), so records written before need nothing extra. Scenes that are not
catalogue families (random-N, dense-N, fixed scenes) have no kind rows.

``python -m pg_policy.evaluation.target_kinds RUN [...]`` prints the table of saved runs: RUN is a results.json or
an output folder of `pushgrasp eval` (its results.json, or the trials.jsonl of a run still going or stopped).
"""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Sequence
from functools import lru_cache
from pathlib import Path

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


def load_trials(path: Path) -> list[TrialRecord]:
    """The trials of a results.json written by `pushgrasp eval`, or of an output folder (results.json, else the
    finished trials in trials.jsonl). Raises FileNotFoundError when there is neither."""
    from pg_policy.evaluation.journal import record_from_dict

    path = Path(path)
    if path.is_dir():
        if (path / "results.json").is_file():
            path = path / "results.json"
        elif (path / "trials.jsonl").is_file():
            lines = (json.loads(line) for line in (path / "trials.jsonl").read_text(encoding="utf-8").splitlines()
                     if line.strip())
            return [record_from_dict(d["trial"]) for d in lines if "trial" in d]
        else:
            raise FileNotFoundError(f"{path}: no results.json or trials.jsonl (not a `pushgrasp eval` output folder)")
    doc = json.loads(path.read_text(encoding="utf-8"))
    return [record_from_dict(t) for t in doc["trials"]]


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m pg_policy.evaluation.target_kinds",
                                     description="C, GS and MN per kind of target of saved `pushgrasp eval` runs.")
    parser.add_argument("runs", nargs="+", type=Path,
                        help="results.json files or `pushgrasp eval` output folders (a folder without results.json: "
                             "the finished trials of its trials.jsonl)")
    args = parser.parse_args(argv)
    from pg_policy.evaluation.report import kind_lines

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
