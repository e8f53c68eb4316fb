"""The policy loop's inputs and outputs over ROS: the latest /pg/heightmap and the controller's
/pg/execute_primitive service (pg_policy.target_loop.target_loop's HeightmapSource and PrimitiveExecutor)."""

from __future__ import annotations

import concurrent.futures
import threading
import time
from collections.abc import Callable
from typing import Any

import rospy
from geometry_msgs.msg import PointStamped
from pg_msgs.msg import Heightmap as HeightmapMsg
from pg_msgs.srv import ExecutePrimitive, ExecutePrimitiveRequest

from pg_conversions.heightmap_msg import heightmap_from_msg
from pg_policy.ros import convert
from pg_policy.target_loop.loop_types import Execution, LoopError, NoHeightmap, StampedHeightmap


class TopicHeightmapSource:
    """Latest /pg/heightmap message (queue 1, large buffer: never a backlog of stale frames)."""

    def __init__(self, topic: str) -> None:
        self.cond_ = threading.Condition()
        self.msg_: HeightmapMsg | None = None
        self.sub_ = rospy.Subscriber(topic, HeightmapMsg, self._on_msg, queue_size=1, buff_size=2**24)
        self.topic_ = topic

    def _on_msg(self, msg: HeightmapMsg) -> None:
        with self.cond_:
            self.msg_ = msg
            self.cond_.notify_all()

    def wait_after(self, stamp: float, timeout_s: float) -> StampedHeightmap:
        deadline = time.monotonic() + timeout_s
        with self.cond_:
            while self.msg_ is None or self.msg_.header.stamp.to_sec() <= stamp:
                left = deadline - time.monotonic()
                if left <= 0 or rospy.is_shutdown():
                    raise NoHeightmap(f"no new heightmap on {self.topic_} within {timeout_s:.1f} s "
                                      "(is the camera publishing and the heightmap projector running?)")
                self.cond_.wait(min(left, 0.1))
            msg = self.msg_
        return StampedHeightmap(heightmap_from_msg(msg), msg.header.stamp.to_sec())


# Wall seconds the executor waits for the controller's answer past the call's remaining budget: the time the answer
# takes to arrive once the controller ends the primitive at that budget.
ANSWER_MARGIN_S = 0.5
# Wall seconds to wait for the service to be advertised (less when the call's budget ends sooner).
SERVICE_WAIT_S = 2.0


def primitive_wait_s(timeout: float) -> float:
    """Longest wall seconds a primitive with this `timeout` (s; the request's field) is waited for when the call's
    budget allows more: the primitive, its return home (as long again) and 10 s of slack."""
    return 2.0 * timeout + 10.0


class ServiceExecutor:
    """Runs primitives through the controller's service (PrimitiveExecutor). Every call is bounded in wall time: it
    answers within `timeout_s` (the call's remaining budget, as TargetLoop passes it) plus ANSWER_MARGIN_S, whatever the
    controller does (frozen, slow, dead). The request carries the instant the executor stops waiting as its `deadline`,
    so a controller that takes it up later refuses it: an abandoned primitive never runs.

    name: the service; timeout_s: the most seconds a primitive may take (the request's `timeout`, ROS time).
    proxy: the service proxy (default rospy.ServiceProxy(name, ExecutePrimitive)); ros_clock: ROS time (s) for the
    Execution's duration and end stamp (default rospy.get_time)."""

    def __init__(self, name: str, timeout_s: float, proxy: Any = None,
                 ros_clock: Callable[[], float] = rospy.get_time) -> None:
        self.name_, self.timeout_s_ = name, timeout_s
        self.proxy_ = proxy if proxy is not None else rospy.ServiceProxy(name, ExecutePrimitive)
        self.ros_clock_ = ros_clock
        # One worker: a call the executor gave up on keeps it until the controller answers or its connection breaks,
        # and later calls are refused meanwhile (below) rather than queued behind it.
        self.pool_ = concurrent.futures.ThreadPoolExecutor(max_workers=1)
        self.pending_: concurrent.futures.Future | None = None

    def execute(self, decision, timeout_s: float) -> Execution:
        """Run the decision's primitive, its `timeout` the smaller of the executor's and `timeout_s`. Raises LoopError
        when the service is not advertised, the call fails, or no answer comes within the wait: `timeout_s` (or the
        primitive's own bound, primitive_wait_s, when shorter) plus ANSWER_MARGIN_S wall seconds."""
        timeout = min(self.timeout_s_, timeout_s)
        wait_s = min(timeout_s, primitive_wait_s(timeout)) + ANSWER_MARGIN_S
        give_up = time.monotonic() + wait_s

        def left() -> float:
            return max(give_up - time.monotonic(), 0.0)

        if self.pending_ is not None:  # an earlier request still unanswered: wait for it within this call's bound
            concurrent.futures.wait([self.pending_], timeout=left())
            if not self.pending_.done():
                raise LoopError(f"{self.name_}: the controller did not answer within {wait_s:.1f} s: it has not "
                                "answered an earlier request either (frozen?); nothing sent")
            self.pending_ = None
        try:
            self.proxy_.wait_for_service(timeout=max(min(SERVICE_WAIT_S, left()), 0.01))
        except rospy.ROSException:
            raise LoopError(f"controller service {self.name_} is not available") from None
        req = ExecutePrimitiveRequest(primitive=(ExecutePrimitiveRequest.GRASP if decision.primitive == "grasp"
                                                 else ExecutePrimitiveRequest.PUSH),
                                      yaw=float(decision.yaw), timeout=timeout)
        req.position = PointStamped()
        req.position.header.frame_id = convert.WORLD
        req.position.point.x, req.position.point.y, req.position.point.z = decision.position
        req.deadline = time.time() + left()  # wall clock of the controller: the instant this executor stops waiting
        t0 = self.ros_clock_()
        future = self.pool_.submit(self.proxy_.call, req)
        self.pending_ = future
        try:
            res = future.result(timeout=left())
        except concurrent.futures.TimeoutError:
            raise LoopError(f"{self.name_}: the controller did not answer within {wait_s:.1f} s; the request is "
                            "abandoned (its deadline has passed: the controller will not start it)") from None
        except (rospy.ServiceException, rospy.ROSException) as exc:
            raise LoopError(f"{self.name_} failed: {exc}") from None
        finally:
            if future.done():
                self.pending_ = None
        t1 = self.ros_clock_()
        return Execution(res.success, res.grasped, res.arm, res.message, t1 - t0, t1)
