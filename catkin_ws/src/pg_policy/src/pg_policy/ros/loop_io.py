"""The policy loop's inputs and outputs over ROS: the latest /pg/heightmap and the controller's
/pg/execute_primitive service (pg_policy.target_loop.target_loop's HeightmapSource and PrimitiveExecutor)."""

from __future__ import annotations

import concurrent.futures
import threading
import time

import rospy
from geometry_msgs.msg import PointStamped
from pg_msgs.msg import Heightmap as HeightmapMsg
from pg_msgs.srv import ExecutePrimitive, ExecutePrimitiveRequest

from pg_conversions.heightmap_msg import heightmap_from_msg
from pg_policy.ros import convert
from pg_policy.target_loop.target_loop import Execution, LoopError, NoHeightmap, StampedHeightmap


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


class ServiceExecutor:
    """Runs primitives through the controller's service; every call is bounded in wall time."""

    def __init__(self, name: str, timeout_s: float) -> None:
        self.name_, self.timeout_s_ = name, timeout_s
        self.proxy_ = rospy.ServiceProxy(name, ExecutePrimitive)
        self.pool_ = concurrent.futures.ThreadPoolExecutor(max_workers=1)

    def execute(self, decision, timeout_s: float) -> Execution:
        try:
            self.proxy_.wait_for_service(timeout=2.0)
        except rospy.ROSException:
            raise LoopError(f"controller service {self.name_} is not available") from None
        req = ExecutePrimitiveRequest(primitive=(ExecutePrimitiveRequest.GRASP if decision.primitive == "grasp"
                                                 else ExecutePrimitiveRequest.PUSH),
                                      yaw=float(decision.yaw), timeout=min(self.timeout_s_, timeout_s))
        req.position = PointStamped()
        req.position.header.frame_id = convert.WORLD
        req.position.point.x, req.position.point.y, req.position.point.z = decision.position
        t0 = rospy.get_time()
        future = self.pool_.submit(self.proxy_.call, req)
        try:
            res = future.result(timeout=req.timeout * 2 + 10.0)
        except concurrent.futures.TimeoutError:
            raise LoopError(f"{self.name_} did not answer within {req.timeout * 2 + 10.0:.0f} s") from None
        except (rospy.ServiceException, rospy.ROSException) as exc:
            raise LoopError(f"{self.name_} failed: {exc}") from None
        t1 = rospy.get_time()
        return Execution(res.success, res.grasped, res.arm, res.message, t1 - t0, t1)
