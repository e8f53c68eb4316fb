"""The hand-eye calibration's tour (ROS-free): the arm carries the board through planned joint targets, a view is
captured at each, and the arm goes back to where it started, also when a move fails.

The caller gives the motion and the capture as functions (pg_policy.ros.hand_eye_node: joint trajectories and
camera images over ROS; unit tests: fakes): `move(q)` brings the arm to joints `q` (rad) and returns None, or a
reason why it did not; `capture()` returns (kept, message) for one view. Nothing here waits: the functions do,
within their own timeouts.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np

Move = Callable[[np.ndarray], "str | None"]
Capture = Callable[[], "tuple[bool, str]"]


class TourAborted(RuntimeError):
    """A move failed: the tour stopped there (the arm was sent back to its start; `report` says how far it got)."""

    def __init__(self, message: str, report: TourReport) -> None:
        super().__init__(message)
        self.report = report


@dataclass
class TourReport:
    """Targets planned and visited, views kept, and one line per target (its capture's message)."""

    planned: int
    visited: int = 0
    kept: int = 0
    lines: list[str] = field(default_factory=list)

    def summary(self) -> str:
        return f"{self.visited} of {self.planned} poses visited, {self.kept} views kept"


def run_tour(plan: Sequence[np.ndarray], start: np.ndarray, move: Move, capture: Capture,
             progress: Callable[[str], None] | None = None) -> TourReport:
    """Visit `plan` in order, capture at each target, then return to `start`. Raises TourAborted when a move
    fails (after trying to return to `start`; the message says both)."""
    report = TourReport(planned=len(plan))
    say = progress or (lambda _line: None)
    for i, q in enumerate(plan):
        why = move(np.asarray(q, dtype=np.float64))
        if why is not None:
            back = move(np.asarray(start, dtype=np.float64))
            raise TourAborted(f"pose {i + 1} of {len(plan)}: {why}; "
                              + ("the arm is back at its start" if back is None else f"return to start: {back}"),
                              report)
        report.visited += 1
        kept, message = capture()
        report.kept += int(kept)
        report.lines.append(f"pose {i + 1}: {message}")
        say(f"pose {i + 1} of {len(plan)}: {message}")
    why = move(np.asarray(start, dtype=np.float64))
    if why is not None:
        raise TourAborted(f"return to start: {why}", report)
    return report
