"""The trial journal of an evaluation run: every finished trial on disk as it ends, so a run that is stopped
(Ctrl-C, a lost machine) resumes where it stopped.

``<out>/trials.jsonl``: line 1 is ``{"run": key}``, the settings that decide the trials' outcomes (policy, model
files and their SHA-256, scenes, trials, seed, limits, jitter, options, rules, geometry); every further line is
``{"trial": record}`` (TrialRecord.to_dict) appended and flushed when the trial ends, in the order trials finish.
Opening a journal whose key differs raises JournalMismatch naming the settings that differ (use another --out, or
--fresh to discard it); a last line cut off by a crash is ignored, a corrupt line elsewhere raises ValueError.
Nothing is written until the first trial ends, so a command refused for bad arguments leaves --out as it was.
"""

from __future__ import annotations

import hashlib
import json
from dataclasses import fields
from pathlib import Path
from typing import Any

from pg_policy.target_loop.records import TrialRecord

JOURNAL = "trials.jsonl"
# the config entries of `pushgrasp eval` that do not decide outcomes (pg_learning.cli.eval); cpu_kernels decides them
# only as another machine does (pg_core.cpu_kernels), so a run resumed with other kernels keeps its finished trials
VOLATILE = ("git_commit", "started", "workers", "host_cpus", "wall_s", "ray", "resumed_trials", "cpu_kernels")


class JournalMismatch(ValueError):
    """The output directory holds the journal of a run with other settings."""


def run_key(config: dict[str, Any]) -> dict[str, Any]:
    """The entries of an eval config that decide the trials' outcomes (JSON-normalised)."""
    return json.loads(json.dumps({k: v for k, v in config.items() if k not in VOLATILE}, sort_keys=True, default=str))


def file_digests(paths: list[str]) -> list[str]:
    """SHA-256 (hex) of each file; '' for a path that is not a file."""
    out = []
    for p in paths:
        path = Path(p)
        out.append(hashlib.sha256(path.read_bytes()).hexdigest() if path.is_file() else "")
    return out


def record_from_dict(d: dict[str, Any]) -> TrialRecord:
    """The TrialRecord of TrialRecord.to_dict's output (derived entries dropped)."""
    names = {f.name for f in fields(TrialRecord)}
    return TrialRecord(**{k: v for k, v in d.items() if k in names})


def read_journal(path: Path) -> tuple[dict[str, Any], list[TrialRecord]]:
    """(run key, finished trials in the order they finished) of a trial journal file. A last line cut off by a
    crash or still being written is ignored; raises ValueError for a corrupt line elsewhere or a file without the
    run line."""
    path = Path(path)
    lines = path.read_text(encoding="utf-8").splitlines()
    entries = []
    for n, line in enumerate(lines):
        try:
            entries.append(json.loads(line))
        except json.JSONDecodeError as exc:
            if n == len(lines) - 1:  # the line being written when the run was stopped
                break
            raise ValueError(f"{path}: line {n + 1} is not JSON ({exc}); remove the file or use --fresh") from exc
    if not entries or "run" not in entries[0]:
        raise ValueError(f"{path} is not a trial journal (no run line); remove it or use --fresh")
    return entries[0]["run"], [record_from_dict(e["trial"]) for e in entries[1:]]


class TrialJournal:
    """Finished trials of one run in `<out>/trials.jsonl` (module docstring)."""

    def __init__(self, out: Path, key: dict[str, Any], fresh: bool = False) -> None:
        self.path = Path(out) / JOURNAL
        self.key = run_key(key)
        self.done: dict[tuple[str, int], TrialRecord] = {}
        if self.path.exists() and not fresh:
            self._load()
        self._fresh = fresh or not self.path.exists()

    def _load(self) -> None:
        old, records = read_journal(self.path)
        if old != self.key:
            diff = sorted(k for k in set(old) | set(self.key) if old.get(k) != self.key.get(k))
            raise JournalMismatch(f"{self.path.parent} holds trials of a run with other settings ({', '.join(diff)} "
                                  "differ): use another --out, or --fresh to discard them")
        for rec in records:
            self.done[(rec.scene, int(rec.seed))] = rec

    def pending(self, jobs: list[tuple[str, int]]) -> list[int]:
        """Indices of `jobs` ((scene, seed) pairs) with no finished trial in the journal."""
        return [i for i, (name, seed) in enumerate(jobs) if (name, int(seed)) not in self.done]

    def add(self, rec: TrialRecord) -> None:
        """Append a finished trial (the run line first when the file is new or --fresh); flushed at once."""
        self.path.parent.mkdir(parents=True, exist_ok=True)
        mode = "w" if self._fresh else "a"
        with self.path.open(mode, encoding="utf-8") as f:
            if self._fresh:
                f.write(json.dumps({"run": self.key}) + "\n")
                self._fresh = False
            f.write(json.dumps({"trial": rec.to_dict()}) + "\n")
        self.done[(rec.scene, int(rec.seed))] = rec

    def records(self, jobs: list[tuple[str, int]]) -> list[TrialRecord]:
        """The finished records of `jobs`, in job order (jobs without one are left out)."""
        return [self.done[(n, int(s))] for n, s in jobs if (n, int(s)) in self.done]
