"""Pacing of simulated time against wall time, and fixed-rate outputs in sim time (no ROS)."""

from __future__ import annotations

import time
from collections.abc import Callable


class Pacer:
    """Keeps sim time at most `factor` times faster than wall time (factor <= 0: no limit).

    Re-anchors when the factor changes or when the sim falls more than `max_lag` wall seconds behind, so a slow
    stretch is never followed by a burst. Sleeps only when at least `min_sleep` s ahead (fewer wake-ups).
    """

    def __init__(self, busy_factor: float, idle_factor: float, clock: Callable[[], float] = time.monotonic,
                 sleep: Callable[[float], None] = time.sleep, max_lag: float = 0.1, min_sleep: float = 0.004) -> None:
        self.busy_factor = busy_factor
        self.idle_factor = idle_factor
        self.clock_ = clock
        self.sleep_ = sleep
        self.max_lag_ = max_lag
        self.min_sleep_ = min_sleep
        self.anchor_: tuple[float, float] | None = None  # (wall, sim)
        self.factor_ = 0.0
        self.slept = 0.0  # total wall seconds slept

    def reanchor(self) -> None:
        self.anchor_ = None

    def pace(self, sim_time: float, busy: bool) -> float:
        """Sleep as needed after a step that reached ``sim_time``; returns the seconds slept."""
        factor = self.busy_factor if busy else self.idle_factor
        now = self.clock_()
        if factor <= 0.0:
            self.anchor_ = None
            return 0.0
        if self.anchor_ is None or factor != self.factor_:
            self.anchor_, self.factor_ = (now, sim_time), factor
            return 0.0
        delay = self.anchor_[0] + (sim_time - self.anchor_[1]) / factor - now
        if delay < -self.max_lag_:
            self.anchor_ = (now, sim_time)
            return 0.0
        if delay < self.min_sleep_:
            return 0.0
        self.sleep_(delay)
        self.slept += delay
        return delay


class Periodic:
    """Due times of a fixed-rate output in sim time (never bursts to catch up after a jump)."""

    def __init__(self, rate: float) -> None:
        self.period = 1.0 / rate if rate > 0 else 0.0
        self.next = 0.0

    def due(self, t: float) -> bool:
        if self.period <= 0.0 or t + 1e-9 < self.next:
            return False
        self.next = max(self.next + self.period, t + 0.5 * self.period)
        return True

    def force(self, t: float) -> None:
        self.next = t
