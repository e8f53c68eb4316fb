"""pg_policy.ros.loop_io.ServiceExecutor against fake service proxies (no ROS master): a frozen, slow or dead
controller never holds a call past its budget plus 2 s, and every request carries the instant the executor stops
waiting as its deadline."""

from __future__ import annotations

import math
import threading
import time

import pytest
import rospy
from test_target_loop import Clock, Policy, Source

from pg_policy.decision.decision import Decision
from pg_policy.ros.loop_io import ANSWER_MARGIN_S, ServiceExecutor, primitive_wait_s
from pg_policy.target_loop.loop_limits import LoopLimits
from pg_policy.target_loop.loop_types import LoopError
from pg_policy.target_loop.target_loop import TargetLoop

BUDGET_SLACK_S = 2.0  # a call answers within its budget plus this (wall s)
DECISION = Decision("grasp", 4, 110, 110, 0.9, math.pi / 2, 0.01, -0.02, 0.02, 0.9)


class Answer:
    success, grasped, arm, message = True, False, "left", "grasped"


class FakeProxy:
    """A service proxy whose call answers after `delay_s` wall seconds (None: only once `release` is set, i.e. a
    frozen controller), or raises `error`; records every request."""

    def __init__(self, delay_s: float | None = None, error: Exception | None = None,
                 available: bool = True) -> None:
        self.delay_s, self.error, self.available = delay_s, error, available
        self.release = threading.Event()
        self.requests: list = []

    def wait_for_service(self, timeout: float) -> None:
        assert 0 < timeout <= 2.0
        if not self.available:
            raise rospy.ROSException("timeout exceeded while waiting for service")

    def call(self, req):
        self.requests.append(req)
        if self.error is not None:
            raise self.error
        self.release.wait(self.delay_s if self.delay_s is not None else 60.0)  # bounded: the test process ends
        return Answer()


@pytest.fixture
def proxies():
    made: list[FakeProxy] = []
    yield made
    for p in made:  # let frozen calls return so their worker threads end
        p.release.set()


def executor(proxies: list[FakeProxy], **kwargs) -> tuple[ServiceExecutor, FakeProxy]:
    proxy = FakeProxy(**kwargs)
    proxies.append(proxy)
    return ServiceExecutor("/pg/execute_primitive", 60.0, proxy=proxy, ros_clock=time.monotonic), proxy


def test_frozen_controller_answers_within_budget(proxies):
    ex, proxy = executor(proxies)
    t0, wall0 = time.monotonic(), time.time()
    with pytest.raises(LoopError, match="the controller did not answer within 2.0 s"):
        ex.execute(DECISION, 1.5)
    took = time.monotonic() - t0
    assert 1.5 <= took <= 1.5 + BUDGET_SLACK_S
    (req,) = proxy.requests
    assert req.timeout == 1.5  # the primitive gets what is left of the call's budget
    # its deadline is the instant the executor gave up: a controller taking it up later refuses it
    assert wall0 + 1.5 < req.deadline <= wall0 + 1.5 + ANSWER_MARGIN_S + 0.05
    assert req.deadline <= time.time()


def test_target_loop_call_with_frozen_controller_ends_within_budget(proxies):
    ex, _ = executor(proxies)
    clock = Clock()
    loop = TargetLoop(Policy("grasp"), Source(clock), ex, clock)
    t0 = time.monotonic()
    res = loop.run("green", LoopLimits(timeout_s=2.0))
    assert time.monotonic() - t0 <= 2.0 + BUDGET_SLACK_S
    assert not res.success and "the controller did not answer" in res.message


def test_slow_controller_is_given_up_at_the_budget(proxies):
    ex, proxy = executor(proxies, delay_s=5.0)
    t0 = time.monotonic()
    with pytest.raises(LoopError, match="did not answer"):
        ex.execute(DECISION, 1.0)
    assert time.monotonic() - t0 <= 1.0 + BUDGET_SLACK_S


def test_answer_within_the_wait_is_returned(proxies):
    ex, proxy = executor(proxies, delay_s=0.2)
    out = ex.execute(DECISION, 5.0)
    assert out.success and out.arm == "left" and 0.15 <= out.duration <= 2.0
    req = proxy.requests[0]
    assert req.primitive == req.GRASP and req.position.header.frame_id == "world"
    assert (req.position.point.x, req.position.point.y, req.yaw) == (0.01, -0.02, math.pi / 2)


def test_dead_controller_is_an_error_at_once(proxies):
    ex, _ = executor(proxies, error=rospy.ServiceException("unable to connect to service: connection refused"))
    t0 = time.monotonic()
    with pytest.raises(LoopError, match="failed: unable to connect"):
        ex.execute(DECISION, 30.0)
    assert time.monotonic() - t0 < 1.0
    gone, _ = executor(proxies, available=False)
    with pytest.raises(LoopError, match="is not available"):
        gone.execute(DECISION, 30.0)


def test_a_request_after_an_unanswered_one_is_not_sent(proxies):
    ex, proxy = executor(proxies)
    with pytest.raises(LoopError):
        ex.execute(DECISION, 1.0)
    t0 = time.monotonic()
    with pytest.raises(LoopError, match="has not answered an earlier request"):
        ex.execute(DECISION, 1.0)
    assert time.monotonic() - t0 <= 1.0 + BUDGET_SLACK_S and len(proxy.requests) == 1
    proxy.release.set()  # the controller resumes and answers the abandoned request: the executor serves again
    proxy.delay_s, proxy.release = 0.0, threading.Event()
    assert ex.execute(DECISION, 5.0).success and len(proxy.requests) == 2


def test_wait_is_bounded_by_the_primitive_when_the_budget_is_long(proxies):
    ex, _ = executor(proxies)
    ex.timeout_s_ = 0.25  # the node's ~primitive_timeout: the wait is primitive_wait_s(0.25) + the margin
    t0 = time.monotonic()
    with pytest.raises(LoopError, match="did not answer"):
        ex.execute(DECISION, 600.0)
    assert time.monotonic() - t0 <= primitive_wait_s(0.25) + ANSWER_MARGIN_S + 1.0
