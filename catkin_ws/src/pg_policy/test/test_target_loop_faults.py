"""pg_policy.target_loop under faults: request limits out of range, a scene reset between primitives, a time budget
below one second, calls arriving on many threads (scripted source, executor and policy of test_target_loop)."""

from __future__ import annotations

import math
import threading

import pytest
from test_target_loop import Executor, make

from pg_policy.target_loop.loop_limits import LoopLimits, request_limits
from pg_policy.target_loop.target_loop import RESET_MESSAGE, TargetLoop

DEFAULTS = LoopLimits(30, 5, 600.0)


@pytest.mark.parametrize(("field", "kwargs"), [
    ("max_actions", {"max_actions": -1}),
    ("max_failed_grasps", {"max_failed_grasps": -3}),
    ("timeout", {"timeout": math.nan}),
    ("timeout", {"timeout": math.inf}),
    ("timeout", {"timeout": -math.inf}),
    ("timeout", {"timeout": -0.5}),
    ("timeout", {"timeout": 1e308}),
    ("max_actions", {"max_actions": 2**31 - 1}),
    ("max_failed_grasps", {"max_failed_grasps": 2**31 - 1}),
])
def test_request_limits_refuse_bad_fields_by_name(field, kwargs):
    req = {"max_actions": 0, "max_failed_grasps": 0, "timeout": 0.0} | kwargs
    with pytest.raises(ValueError, match=rf"^{field} must be"):
        request_limits(req["max_actions"], req["max_failed_grasps"], req["timeout"], DEFAULTS)


def test_request_limits_zero_means_default_and_fractions_stay():
    assert request_limits(0, 0, 0.0, DEFAULTS) == DEFAULTS
    assert request_limits(3, 1, 0.5, DEFAULTS) == LoopLimits(3, 1, 0.5)


def test_loop_limits_name_the_field():
    with pytest.raises(ValueError, match="^max_failed_grasps"):
        LoopLimits(max_failed_grasps=0)
    with pytest.raises(ValueError, match="^timeout"):
        LoopLimits(timeout_s=math.inf)


def test_sub_second_budget_is_reported_as_given(monkeypatch):
    loop, _, ex, _ = make([(True, False, False)], primitive="push")
    wall = iter(range(0, 1000, 1))  # every monotonic reading one second later
    monkeypatch.setattr("pg_policy.target_loop.target_loop.time.monotonic", lambda: float(next(wall)))
    res = loop.run("green", LoopLimits(timeout_s=0.5))
    assert res.message == "time budget of 0.5 s spent" and len(ex.calls) == 1


class Resets:
    """A scene token that changes when the executor has run `after` primitives (None: never heard of)."""

    def __init__(self, ex: Executor, after: int, start: int | None = 0) -> None:
        self.ex, self.after, self.start = ex, after, start

    def __call__(self) -> int | None:
        if self.start is None:
            return None
        return self.start + (1 if len(self.ex.calls) >= self.after else 0)


def with_resets(loop: TargetLoop, resets: Resets) -> TargetLoop:
    loop.scene_epoch = resets
    return loop


def test_reset_between_pushes_ends_the_call():
    loop, _, ex, records = make([(True, False, False)], primitive="push")
    res = with_resets(loop, Resets(ex, after=2)).run("green")
    assert res.message == f"{RESET_MESSAGE}: stopped after 2 actions" and not res.success
    assert len(ex.calls) == 2 and res.pushes == 2 and len(records) == 2


def test_reset_after_a_grasp_is_not_judged_on_the_new_scene():
    """The target vanishing from the next heightmap would count as grasped; after a reset that proves nothing."""
    loop, _, ex, records = make([(True, True, True)])
    res = with_resets(loop, Resets(ex, after=1)).run("green")
    assert not res.success and res.message.startswith(RESET_MESSAGE)
    assert len(records) == 1 and not records[0].target_grasped and len(ex.calls) == 1


def test_no_reset_topic_changes_nothing():
    loop, _, ex, _ = make([(True, False, False)], primitive="push")
    res = with_resets(loop, Resets(ex, after=1, start=None)).run("green", LoopLimits(max_actions=4))
    assert len(ex.calls) == 4 and "budget" in res.message


def test_a_token_first_heard_during_the_call_is_its_baseline():
    loop, _, ex, _ = make([(True, False, False)], primitive="push")
    heard = {"value": None}

    def token() -> int | None:
        if len(ex.calls) >= 1:
            heard["value"] = 7 if len(ex.calls) < 3 else 8
        return heard["value"]

    loop.scene_epoch = token
    res = loop.run("green")
    assert res.message == f"{RESET_MESSAGE}: stopped after 3 actions" and len(ex.calls) == 3


def test_a_new_call_starts_from_the_current_scene():
    loop, _, ex, _ = make([(True, False, False)], primitive="push")
    with_resets(loop, Resets(ex, after=2)).run("green", LoopLimits(max_actions=5))
    res = loop.run("green", LoopLimits(max_actions=3))
    assert "budget" in res.message and len(ex.calls) == 5


def test_policy_runs_on_one_thread_whoever_calls():
    """rospy serves each service connection on a new thread; the nets must still run on one (module worker)."""
    loop, _, ex, _ = make([(True, False, False)], primitive="push")
    seen: set[int] = set()
    act = loop.policy.act
    loop.policy.act = lambda obs: (seen.add(threading.get_ident()), act(obs))[1]
    two = LoopLimits(max_actions=2)
    callers = [threading.Thread(target=f) for f in (lambda: loop.run("green", two), lambda: loop.infer("green"),
                                                    lambda: loop.run("green", two))]
    for t in callers:
        t.start()
        t.join()
    assert len(ex.calls) == 4 and len(seen) == 1 and seen == {loop.worker.ident}
    assert not seen & {t.ident for t in callers} and threading.get_ident() not in seen


def test_a_reset_count_arriving_before_the_first_primitive_means_a_fresh_decision_not_a_stop():
    """The count of the reset that preceded the call may arrive after the call started: nothing has moved, so the
    call decides anew and goes on."""
    loop, _, ex, records = make([(True, False, False)], primitive="push")
    heard = iter([0, 1])  # the call starts with the old count, the reset's count arrives before any action
    loop.scene_epoch = lambda: next(heard, 1)
    res = loop.run("green", LoopLimits(max_actions=3))
    assert len(ex.calls) == 3 and "budget" in res.message and not res.message.startswith(RESET_MESSAGE)
