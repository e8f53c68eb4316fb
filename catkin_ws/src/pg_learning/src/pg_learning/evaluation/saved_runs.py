"""Reading the output folders that `pushgrasp eval` writes, for the reports (`pushgrasp compare`, `pushgrasp kinds`).

An output folder holds results.json once its run has finished and trials.jsonl (pg_learning.evaluation.journal) while
it runs or after it was stopped. A saved run is read from results.json when there is one, else from the finished
trials of its journal. Folders of output folders (results/novel/lite, a protocol run's policy folder) are searched
at any depth, following symbolic links (each real folder once); an output folder is not searched below itself.
"""

from __future__ import annotations

import json
import os
from pathlib import Path
from typing import Any

from pg_learning.evaluation.journal import JOURNAL, read_journal, record_from_dict
from pg_policy.target_loop.records import TrialRecord

RESULTS = "results.json"


def is_run_folder(path: Path) -> bool:
    """True when `path` is an output folder of `pushgrasp eval` (it holds results.json or trials.jsonl)."""
    return (path / RESULTS).is_file() or (path / JOURNAL).is_file()


def load_run(path: Path) -> tuple[dict[str, Any], list[TrialRecord]]:
    """(settings, trials) of a results.json written by `pushgrasp eval`, or of an output folder (results.json, else
    its journal: the run key, which leaves out the volatile entries of pg_learning.evaluation.journal.VOLATILE, and
    the finished trials). Each file is read once. Raises FileNotFoundError when there is neither, KeyError or
    ValueError for a file that is not such a record."""
    path = Path(path)
    if path.is_dir():
        if (path / RESULTS).is_file():
            path = path / RESULTS
        elif (path / JOURNAL).is_file():
            return read_journal(path / JOURNAL)
        else:
            raise FileNotFoundError(f"{path}: no {RESULTS} or {JOURNAL} (not a `pushgrasp eval` output folder)")
    doc = json.loads(path.read_text(encoding="utf-8"))
    return dict(doc.get("config", {})), [record_from_dict(t) for t in doc["trials"]]


def load_trials(path: Path) -> list[TrialRecord]:
    """The trials of `load_run(path)`."""
    return load_run(path)[1]


def run_folders(path: Path) -> list[Path]:
    """The output folders at or below `path`, in path order, following symbolic links (a folder reached twice, by
    a link or a link loop, counts once). Raises FileNotFoundError when there is none."""
    path = Path(path)
    if is_run_folder(path):
        return [path]
    found: list[Path] = []
    seen: set[str] = set()
    for root, dirs, _ in os.walk(path, followlinks=True):
        real = os.path.realpath(root)
        if real in seen:
            dirs[:] = []
            continue
        seen.add(real)
        here = Path(root)
        if is_run_folder(here):
            found.append(here)
            dirs[:] = []
        else:
            dirs.sort()
    if not found:
        raise FileNotFoundError(f"{path}: no `pushgrasp eval` output folder in it or below it")
    return sorted(found)


def load_tree(path: Path) -> list[TrialRecord]:
    """The trials of every output folder at or below `path` (run_folders), in path order. Raises FileNotFoundError
    when there is none (or `path` does not exist); `path` may also be a results.json."""
    path = Path(path)
    if not path.is_dir():
        return load_trials(path)
    return [t for d in run_folders(path) for t in load_trials(d)]
