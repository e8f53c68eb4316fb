"""What a probe hands back (figures, tables, checked invariants) and the run's report: report.md and report.json."""

from __future__ import annotations

import json
import math
import os
import platform
import subprocess
import sys
import time
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

Cell = str | int | float | bool | None


@dataclass
class Check:
    """One invariant of a probe: its name, whether it held, and the evidence (counts, the first offending case)."""

    name: str
    passed: bool
    detail: str = ""


@dataclass
class Table:
    title: str
    columns: list[str]
    rows: list[list[Cell]] = field(default_factory=list)


@dataclass
class ProbeResult:
    """A probe's outcome. `error` is set when the probe itself raised (its checks then fail)."""

    name: str
    title: str
    figures: dict[str, Any] = field(default_factory=dict)
    tables: list[Table] = field(default_factory=list)
    checks: list[Check] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)
    error: str | None = None
    duration_s: float = 0.0

    @property
    def passed(self) -> bool:
        return self.error is None and bool(self.checks) and all(c.passed for c in self.checks)

    def check(self, name: str, passed: bool, detail: str = "") -> bool:
        self.checks.append(Check(name, bool(passed), detail))
        return bool(passed)

    def table(self, title: str, columns: list[str]) -> Table:
        t = Table(title, columns)
        self.tables.append(t)
        return t


@dataclass
class Report:
    command: str
    options: dict[str, Any]
    machine: dict[str, Any]
    probes: list[ProbeResult] = field(default_factory=list)
    stack: dict[str, Any] = field(default_factory=dict)
    cleanup: dict[str, Any] = field(default_factory=dict)
    started: str = ""
    wall_s: float = 0.0
    interrupted: bool = False

    @property
    def passed(self) -> bool:
        return (not self.interrupted and bool(self.probes) and all(p.passed for p in self.probes)
                and bool(self.cleanup.get("passed", False)))


def machine_info(repo: Path) -> dict[str, Any]:
    """Cores, load average, memory, Python, OS and the git commit (with a dirty flag) of the checkout."""

    def git(*args: str) -> str:
        try:
            return subprocess.run(["git", *args], cwd=repo, capture_output=True, text=True, timeout=10).stdout.strip()
        except (OSError, subprocess.SubprocessError):
            return ""

    mem_total = ""
    try:
        for line in Path("/proc/meminfo").read_text().splitlines():
            if line.startswith("MemTotal:"):
                mem_total = f"{int(line.split()[1]) / 1024 / 1024:.1f} GiB"
    except OSError:
        pass
    return {"cores": os.cpu_count(), "load_average": [round(v, 2) for v in os.getloadavg()], "memory": mem_total,
            "python": sys.version.split()[0], "platform": platform.platform(), "host": platform.node(),
            "git_commit": git("rev-parse", "HEAD"),
            "git_dirty": bool(git("status", "--porcelain", "--untracked-files=no"))}


def _fmt(v: Cell) -> str:
    if v is None:
        return "-"
    if isinstance(v, bool):
        return "yes" if v else "no"
    if isinstance(v, float):
        if math.isnan(v):
            return "nan"
        return f"{v:.3g}" if abs(v) < 1e-2 or abs(v) >= 1e5 else f"{v:.2f}"
    return str(v).replace("|", "\\|").replace("\n", " ")


def _md_table(columns: list[str], rows: list[list[Cell]]) -> list[str]:
    out = ["| " + " | ".join(columns) + " |", "|" + "---|" * len(columns)]
    out += ["| " + " | ".join(_fmt(c) for c in row) + " |" for row in rows]
    return out


def markdown(rep: Report) -> str:
    m = rep.machine
    lines = ["# pushgrasp reliability report", "",
             f"Result: **{'PASS' if rep.passed else 'FAIL'}** ({sum(p.passed for p in rep.probes)} of "
             f"{len(rep.probes)} probes passed; wall time {rep.wall_s:.0f} s, started {rep.started})", "",
             "Command:", "", "```", rep.command, "```", "",
             f"Machine: {m.get('cores')} cores, load average {m.get('load_average')} at the start and "
             f"{m.get('load_average_end')} at the end, {m.get('memory')} memory, Python {m.get('python')}, "
             f"{m.get('platform')}; git commit {m.get('git_commit')}"
             f"{' (with uncommitted changes)' if m.get('git_dirty') else ''}.",
             "", "## Summary", ""]
    rows: list[list[Cell]] = []
    for p in rep.probes:
        failed = [c.name for c in p.checks if not c.passed] + ([f"probe error: {p.error}"] if p.error else [])
        rows.append([p.name, "PASS" if p.passed else "FAIL", round(p.duration_s, 1),
                     f"{sum(c.passed for c in p.checks)}/{len(p.checks)}", "; ".join(failed) or "-"])
    rows.append(["cleanup", "PASS" if rep.cleanup.get("passed") else "FAIL", None, None,
                 rep.cleanup.get("summary", "-")])
    lines += _md_table(["probe", "result", "time (s)", "invariants held", "failed invariants"], rows)
    if rep.stack:
        lines += ["", "## Stack", ""]
        lines += [f"- {k}: {json.dumps(v) if isinstance(v, list | dict) else _fmt(v)}" for k, v in rep.stack.items()]
    for p in rep.probes:
        lines += ["", f"## {p.title} ({p.name}): {'PASS' if p.passed else 'FAIL'}", ""]
        if p.error:
            lines += [f"Probe error: `{p.error}`", ""]
        if p.figures:
            lines += _md_table(["figure", "value"], [[k, v if not isinstance(v, list | dict) else json.dumps(v)]
                                                       for k, v in p.figures.items()]) + [""]
        for t in p.tables:
            lines += [f"**{t.title}**", ""] + _md_table(t.columns, t.rows) + [""]
        lines += ["Invariants:", ""]
        lines += [f"- [{'x' if c.passed else ' '}] {c.name}{': ' + c.detail if c.detail else ''}" for c in p.checks]
        lines += [f"- note: {n}" for n in p.notes]
    lines += ["", "## Cleanup", ""]
    lines += [f"- {k}: {json.dumps(v) if isinstance(v, list | dict) else _fmt(v)}" for k, v in rep.cleanup.items()]
    return "\n".join(lines) + "\n"


def _jsonable(obj: Any) -> Any:
    if isinstance(obj, float) and not math.isfinite(obj):
        return str(obj)
    if isinstance(obj, dict):
        return {str(k): _jsonable(v) for k, v in obj.items()}
    if isinstance(obj, list | tuple):
        return [_jsonable(v) for v in obj]
    if isinstance(obj, Path):
        return str(obj)
    return obj


def to_json(rep: Report) -> dict[str, Any]:
    d = asdict(rep)
    d["passed"] = rep.passed
    for pd, p in zip(d["probes"], rep.probes, strict=True):
        pd["passed"] = p.passed
    return _jsonable(d)


def write(rep: Report, out: Path) -> tuple[Path, Path]:
    out.mkdir(parents=True, exist_ok=True)
    md, js = out / "report.md", out / "report.json"
    md.write_text(markdown(rep), encoding="utf-8")
    js.write_text(json.dumps(to_json(rep), indent=1, allow_nan=False), encoding="utf-8")
    return md, js


def now_iso() -> str:
    return time.strftime("%Y-%m-%dT%H:%M:%S%z")
