"""rospy shell of the policy (DESIGN.md section 5): /pg/heightmap in; /pg/infer and /pg/grasp_target served;
/pg/decisions, /pg/q_map and /pg/markers out. The loop itself is pg_policy.target_loop.TargetLoop.

Private parameters (defaults): ~policy ("heuristic"; a registry name or a model directory / TorchScript file),
~grasp_threshold (from the model), ~heightmap_timeout (5.0 wall s), ~primitive_timeout (60.0 s per primitive),
~max_actions (30), ~max_failed_grasps (5), ~call_timeout (600 wall s), ~execute_service ("/pg/execute_primitive"),
~dry_run (false: grasp_target refused; every new heightmap is decided on and published on /pg/dry_run/decisions).
A missing or corrupt model file ends the node at start-up with the reason (exit status 1).
"""

from __future__ import annotations

import concurrent.futures
import sys
import threading
import time

import rospy
from geometry_msgs.msg import PointStamped
from pg_msgs.msg import Decision as DecisionMsg
from pg_msgs.msg import Heightmap as HeightmapMsg
from pg_msgs.srv import (
    ExecutePrimitive,
    ExecutePrimitiveRequest,
    GraspTarget,
    GraspTargetResponse,
    Infer,
    InferResponse,
)
from sensor_msgs.msg import Image
from visualization_msgs.msg import MarkerArray

from pg_policy.ros import convert
from pg_policy.target_loop import Execution, LoopError, LoopLimits, NoHeightmap, StampedHeightmap, TargetLoop, mask_of


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
        return StampedHeightmap(convert.heightmap_from_msg(msg), msg.header.stamp.to_sec())


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


class PolicyNode:
    def __init__(self) -> None:
        from pg_policy.policies import PolicyOptions, make_policy

        self.policy_name = str(rospy.get_param("~policy", "heuristic"))
        threshold = rospy.get_param("~grasp_threshold", None)
        policy = make_policy(self.policy_name, PolicyOptions(grasp_threshold=threshold))
        self.limits = LoopLimits(int(rospy.get_param("~max_actions", 30)),
                                 int(rospy.get_param("~max_failed_grasps", 5)),
                                 float(rospy.get_param("~call_timeout", 600.0)))
        self.dry_run = bool(rospy.get_param("~dry_run", False))
        self.source = TopicHeightmapSource("/pg/heightmap")
        executor = ServiceExecutor(str(rospy.get_param("~execute_service", "/pg/execute_primitive")),
                                   float(rospy.get_param("~primitive_timeout", 60.0)))
        self.pub_decisions = rospy.Publisher("/pg/dry_run/decisions" if self.dry_run else "/pg/decisions",
                                             DecisionMsg, queue_size=100)
        self.pub_q = rospy.Publisher("/pg/q_map", Image, queue_size=1, latch=True)
        self.pub_markers = rospy.Publisher("/pg/markers", MarkerArray, queue_size=1, latch=True)
        self.loop = TargetLoop(policy, self.source, executor, rospy.get_time, self.policy_name,
                               float(rospy.get_param("~heightmap_timeout", 5.0)), on_action=self._publish_action,
                               on_decision=self._visualise)
        self.busy = threading.Lock()
        self.hm_: dict[float, object] = {}
        rospy.Service("/pg/infer", Infer, self.on_infer)
        rospy.Service("/pg/grasp_target", GraspTarget, self.on_grasp_target)
        rospy.loginfo("policy node ready: policy %s%s", self.policy_name, " (dry run)" if self.dry_run else "")

    def _publish_action(self, rec) -> None:
        self.pub_decisions.publish(convert.decision_msg(rec, rospy.Time.now()))

    def _visualise(self, rec, shm: StampedHeightmap) -> None:
        target = mask_of(shm.heightmap, rec.target)
        stamp = rospy.Time.from_sec(shm.stamp)
        header = DecisionMsg().header
        header.frame_id, header.stamp = convert.WORLD, stamp
        self.pub_q.publish(convert.image_msg(convert.overlay(shm.heightmap, target, rec, self.loop.last_q), "rgb8",
                                             header))
        self.pub_markers.publish(convert.markers(shm.heightmap, target, rec, stamp))

    def on_infer(self, req) -> InferResponse:
        if not self.busy.acquire(blocking=False):
            return InferResponse(success=False, message="busy: a grasp_target call is running")
        try:
            rec = self.loop.infer(req.target)
            return InferResponse(success=True, message="ok", decision=convert.decision_msg(rec, rospy.Time.now()))
        except (LoopError, ValueError) as exc:
            return InferResponse(success=False, message=str(exc))
        finally:
            self.busy.release()

    def on_grasp_target(self, req) -> GraspTargetResponse:
        if self.dry_run:
            return GraspTargetResponse(success=False, message="dry run: this node executes nothing")
        if not self.busy.acquire(blocking=False):
            return GraspTargetResponse(success=False, message="busy: another grasp_target call is running")
        try:
            limits = LoopLimits(req.max_actions or self.limits.max_actions,
                                req.max_failed_grasps or self.limits.max_failed_grasps,
                                req.timeout or self.limits.timeout_s)
            res = self.loop.run(req.target, limits)
        except (LoopError, ValueError) as exc:
            return GraspTargetResponse(success=False, message=str(exc))
        finally:
            self.busy.release()
        rospy.loginfo("grasp_target %s: %s (%d grasps, %d pushes, %.1f s)", req.target or "green", res.message,
                      res.grasps, res.pushes, res.duration)
        stamp = rospy.Time.now()
        return GraspTargetResponse(success=res.success, grasps=res.grasps, pushes=res.pushes, duration=res.duration,
                                   wall_time=res.wall_time, message=res.message,
                                   decisions=[convert.decision_msg(r, stamp) for r in res.actions])

    def spin_dry_run(self, target: str) -> None:
        """Decide on every new heightmap (nothing executed) until shutdown."""
        last = 0.0
        while not rospy.is_shutdown():
            try:
                shm = self.source.wait_after(last, 1.0)
            except NoHeightmap:
                continue
            last = shm.stamp
            with self.busy:
                try:
                    self.loop.policy.reset(0)  # nothing was executed: no memory of earlier decisions
                    rec = self.loop.decide(target, shm)
                except LoopError as exc:
                    rospy.logwarn_throttle(5.0, str(exc))
                    continue
            self._publish_action(rec)


def main() -> None:
    rospy.init_node("pg_policy")
    try:
        node = PolicyNode()
    except (FileNotFoundError, ValueError, RuntimeError) as exc:
        rospy.logfatal("policy node cannot start: %s", exc)
        sys.exit(1)
    if node.dry_run:
        node.spin_dry_run(str(rospy.get_param("~target", "green")))
    else:
        rospy.spin()
