"""The limits of one grasp-target call: the episode's counts (pg_policy.target_loop.episode.Limits) plus a
wall-clock budget, and their reading from a pg_msgs/GraspTarget request (0 in a field: the node's default).

Raised: ValueError naming the field for a count or timeout outside its range.
"""

from __future__ import annotations

import math
import numbers
from dataclasses import dataclass

from pg_policy.target_loop.episode import Limits

DEFAULT_TIMEOUT_S = 600.0  # the node's default wall-clock budget of a call (s)


@dataclass(frozen=True)
class LoopLimits(Limits):
    """The episode's limits (pg_policy.target_loop.episode.Limits) plus the call's wall-clock budget."""

    timeout_s: float = DEFAULT_TIMEOUT_S  # wall-clock seconds for the whole call

    def __post_init__(self) -> None:
        """ValueError naming the field unless both counts are integers >= 1 and the timeout is finite and > 0."""
        super().__post_init__()
        if not isinstance(self.timeout_s, numbers.Real) or not math.isfinite(self.timeout_s) or self.timeout_s <= 0:
            raise ValueError(f"timeout must be a finite number of seconds > 0, got {self.timeout_s!r}")


MAX_COUNT = 1000  # most actions / failed grasps one request may ask for
MAX_TIMEOUT_S = 86400.0  # longest time budget one request may ask for (s)

def request_limits(max_actions: int, max_failed_grasps: int, timeout: float, defaults: LoopLimits) -> LoopLimits:
    """The limits of one grasp_target request (pg_msgs/GraspTarget): 0 in a field means the default's value.
    ValueError naming the field for a count outside [0, MAX_COUNT] or a NaN, infinite, negative or too long
    timeout (above MAX_TIMEOUT_S)."""
    for name, value in (("max_actions", max_actions), ("max_failed_grasps", max_failed_grasps)):
        if not 0 <= value <= MAX_COUNT:
            raise ValueError(f"{name} must be in [0, {MAX_COUNT}] (0: the node's default {getattr(defaults, name)}), "
                             f"got {value}")
    timeout = float(timeout)
    if not math.isfinite(timeout) or not 0 <= timeout <= MAX_TIMEOUT_S:
        raise ValueError(f"timeout must be a finite number of wall-clock seconds in [0, {MAX_TIMEOUT_S:g}] (0: the "
                         f"node's default {defaults.timeout_s:g} s), got {timeout}")
    return LoopLimits(int(max_actions) or defaults.max_actions, int(max_failed_grasps) or defaults.max_failed_grasps,
                      timeout or defaults.timeout_s)
