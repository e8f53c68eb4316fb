"""pg_policy.perception.calibration_tour with a fake arm and camera: every target visited and captured in order,
the arm sent back to its start at the end and when a move fails."""

from __future__ import annotations

import numpy as np
import pytest

from pg_policy.perception.calibration_tour import TourAborted, run_tour


class FakeArm:
    def __init__(self, fail_at: int | None = None) -> None:
        self.moves: list[np.ndarray] = []
        self.fail_at = fail_at

    def move(self, q: np.ndarray) -> str | None:
        self.moves.append(q.copy())
        if self.fail_at is not None and len(self.moves) == self.fail_at:
            return "the arm did not reach its target"
        return None


def test_every_target_is_visited_and_captured_then_the_arm_returns():
    plan = [np.full(6, float(i)) for i in range(1, 5)]
    start = np.zeros(6)
    arm, shots = FakeArm(), []

    def capture():
        shots.append(len(arm.moves))
        return len(shots) != 2, f"view {len(shots)}"

    report = run_tour(plan, start, arm.move, capture)
    assert [m[0] for m in arm.moves] == [1.0, 2.0, 3.0, 4.0, 0.0]
    assert shots == [1, 2, 3, 4]  # a capture after each target, none after the return
    assert (report.planned, report.visited, report.kept) == (4, 4, 3)
    assert report.summary() == "4 of 4 poses visited, 3 views kept"


def test_a_failed_move_stops_the_tour_and_sends_the_arm_back():
    plan = [np.full(6, float(i)) for i in range(1, 5)]
    arm = FakeArm(fail_at=3)
    with pytest.raises(TourAborted, match="pose 3 of 4: the arm did not reach its target; the arm is back") as exc:
        run_tour(plan, np.zeros(6), arm.move, lambda: (True, "ok"))
    assert [m[0] for m in arm.moves] == [1.0, 2.0, 3.0, 0.0]
    assert (exc.value.report.visited, exc.value.report.kept) == (2, 2)
