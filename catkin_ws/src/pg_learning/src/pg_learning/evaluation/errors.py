"""Trials that end in an error (DESIGN.md section 8: "An error inside a trial (policy or simulator) ends that trial as
a failure with its reason; the run goes on").

A trial whose policy or simulator raised an Exception is recorded with termination ``"error"`` (so it is not
completed: it counts as a failure in C), ``error`` = "ExceptionType: message" on one line cut to ERROR_CHARS
characters, ``error_at`` = the call that raised (one of STAGES) and ``error_trace`` = the innermost frames of the
traceback. BaseExceptions that are not Exceptions (KeyboardInterrupt, SystemExit) are never caught: they stop the run.
"""

from __future__ import annotations

import traceback
from collections.abc import Sequence
from typing import TYPE_CHECKING

from pg_policy.target_loop.episode import ERROR  # the termination of a trial that ended in an error

if TYPE_CHECKING:
    from pg_policy.target_loop.records import TrialRecord

ERROR_CHARS = 300
TRACE_FRAMES = 6
TRACE_CHARS = 2000
# where a trial can fail: building the scene, making the simulator, the trial's calls, and (with --workers) the worker
# process that ran it dying
STAGES = ("scene", "env.make", "policy.reset", "env.reset", "policy.act", "env.step", "env.observe", "worker")


def describe(exc: BaseException, limit: int = ERROR_CHARS) -> str:
    """'Type: message' of `exc` on one line, cut to `limit` characters (ending in '...' when cut)."""
    msg = " ".join(str(exc).split())
    text = f"{type(exc).__name__}: {msg}" if msg else type(exc).__name__
    return text if len(text) <= limit else text[: max(0, limit - 3)] + "..."


def short_trace(exc: BaseException, frames: int = TRACE_FRAMES, limit: int = TRACE_CHARS) -> str:
    """The innermost `frames` frames of `exc`'s traceback as text (file, line, function, source), at most `limit`
    characters (the innermost end kept)."""
    text = "".join(traceback.format_list(traceback.extract_tb(exc.__traceback__)[-frames:]))
    return text[-limit:]


def mark_error(rec: TrialRecord, exc: BaseException | None, stage: str, text: str | None = None) -> TrialRecord:
    """End `rec` as an error trial: not completed, termination "error", the reason (`text`, else describe(exc)), the
    stage and the traceback; the counts and actions recorded so far are kept. Returns `rec`."""
    rec.completed, rec.termination = False, ERROR
    rec.error = text if text is not None else describe(exc) if exc is not None else "unknown error"
    rec.error_at = stage
    rec.error_trace = short_trace(exc) if exc is not None else None
    return rec


def reason(rec: TrialRecord) -> str:
    """'stage: Type: message' of an error trial."""
    why = rec.error or "unknown error"
    return f"{rec.error_at}: {why}" if rec.error_at else why


def error_groups(trials: Sequence[TrialRecord]) -> list[tuple[str, list[TrialRecord]]]:
    """The error trials grouped by reason, most frequent first (ties in first-seen order)."""
    groups: dict[str, list[TrialRecord]] = {}
    for t in trials:
        if t.termination == ERROR:
            groups.setdefault(reason(t), []).append(t)
    return sorted(groups.items(), key=lambda kv: -len(kv[1]))


def reason_lines(trials: Sequence[TrialRecord], show: int = 3) -> list[str]:
    """One markdown list line per distinct error reason: count, reason, the first `show` trials (scene seed)."""
    lines = []
    for why, ts in error_groups(trials):
        where = ", ".join(f"{t.scene} seed {t.seed}" for t in ts[:show]) + (", ..." if len(ts) > show else "")
        lines.append(f"- {len(ts)} × {why} ({where})")
    return lines


def errors_json(trials: Sequence[TrialRecord]) -> list[dict]:
    """The error reasons for results.json: reason, count and the (scene, seed) of every trial."""
    return [{"reason": why, "count": len(ts), "trials": [[t.scene, int(t.seed)] for t in ts]}
            for why, ts in error_groups(trials)]
