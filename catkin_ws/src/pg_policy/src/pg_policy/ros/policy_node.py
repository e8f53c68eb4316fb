"""rospy shell of the policy (DESIGN.md section 5): /pg/heightmap in; /pg/infer and /pg/grasp_target served, and
the action /pg/grasp_target_action (pg_msgs/GraspTargetAction: feedback per action, cancel between actions; a goal
while a call runs is rejected "busy"); /pg/decisions, /pg/q_map and /pg/markers out. The loop itself is
pg_policy.target_loop.target_loop.TargetLoop.

Private parameters (defaults): ~policy ("lite", the shipped model; a registered policy or plugin, a shipped model
folder name, a model directory or a TorchScript file); the declared policy options of pg_policy.policies.options
(~grasp_threshold, ~push_budget, ~rules and each rule's switch such as ~grasp_check, ~edge_guard; unset or "auto":
the model's own), ~heightmap_timeout (5.0 wall s),
~primitive_timeout (60.0 s per primitive), ~max_actions (30), ~max_failed_grasps (5), ~call_timeout (600 wall s),
~execute_service ("/pg/execute_primitive"), ~dry_run (false: grasp_target refused; every new heightmap is decided
on and published on /pg/dry_run/decisions), ~scene_resets_topic ("/pg_sim/scene_resets": std_msgs/UInt32, latched,
the simulator's count of scene resets; a change during a call ends it with "the scene was reset during the call";
on a real cell nothing publishes it and the subscriber never fires).
A missing or corrupt model file, or a limit parameter out of range, ends the node at start-up with the reason (exit
status 1). A request with a negative max_actions / max_failed_grasps or a NaN, infinite or negative timeout is
refused with a message naming the field; nothing moves. The answer's message says why a call ended (the episode
protocol's reason, pg_policy.target_loop.episode): "target 'green' grasped", "target lost: <why>" (it left the
workspace), "gave up after 5 failed grasps", "action budget of 30 spent", "cancelled", ...
Threads: every policy computation runs on the TargetLoop's one worker thread, whichever service or action thread
asked (pg_policy.target_loop.worker: keeps the RSS flat over calls).
"""

from __future__ import annotations

import sys
import threading

import actionlib
import rospy
from pg_msgs.msg import Decision as DecisionMsg
from pg_msgs.msg import GraspTargetAction, GraspTargetFeedback, GraspTargetResult
from pg_msgs.srv import GraspTarget, GraspTargetResponse, Infer, InferResponse
from sensor_msgs.msg import Image
from std_msgs.msg import UInt32
from visualization_msgs.msg import MarkerArray

from pg_conversions.heightmap_msg import image_msg
from pg_policy.policies import options
from pg_policy.policies.policy import PolicyOptions
from pg_policy.policies.registry import make_policy
from pg_policy.ros import convert
from pg_policy.ros.loop_io import ServiceExecutor, TopicHeightmapSource
from pg_policy.target_loop.episode import CANCELLED, DEFAULT_MAX_ACTIONS, DEFAULT_MAX_FAILED_GRASPS
from pg_policy.target_loop.target_loop import (
    DEFAULT_TIMEOUT_S,
    LoopError,
    LoopLimits,
    NoHeightmap,
    StampedHeightmap,
    TargetLoop,
    mask_of,
    request_limits,
)

BUSY = "busy: another grasp_target call is running"


class PolicyNode:
    def __init__(self) -> None:
        self.policy_name = str(rospy.get_param("~policy", "lite"))
        policy = make_policy(self.policy_name, PolicyOptions(overrides=options.from_params(rospy.get_param)))
        self.limits = LoopLimits(int(rospy.get_param("~max_actions", DEFAULT_MAX_ACTIONS)),
                                 int(rospy.get_param("~max_failed_grasps", DEFAULT_MAX_FAILED_GRASPS)),
                                 float(rospy.get_param("~call_timeout", DEFAULT_TIMEOUT_S)))
        self.dry_run = bool(rospy.get_param("~dry_run", False))
        self.source = TopicHeightmapSource("/pg/heightmap")
        executor = ServiceExecutor(str(rospy.get_param("~execute_service", "/pg/execute_primitive")),
                                   float(rospy.get_param("~primitive_timeout", 60.0)))
        self.pub_decisions = rospy.Publisher("/pg/dry_run/decisions" if self.dry_run else "/pg/decisions",
                                             DecisionMsg, queue_size=100)
        self.pub_q = rospy.Publisher("/pg/q_map", Image, queue_size=1, latch=True)
        self.pub_markers = rospy.Publisher("/pg/markers", MarkerArray, queue_size=1, latch=True)
        self.scene_resets_: int | None = None  # latest simulator reset count; None: none heard (a real cell)
        self.sub_resets_ = rospy.Subscriber(str(rospy.get_param("~scene_resets_topic", "/pg_sim/scene_resets")),
                                            UInt32, self._on_scene_resets, queue_size=10)
        self.loop = TargetLoop(policy, self.source, executor, rospy.get_time, self.policy_name,
                               float(rospy.get_param("~heightmap_timeout", 5.0)), on_action=self._publish_action,
                               on_decision=self._visualise, scene_epoch=lambda: self.scene_resets_)
        self.busy = threading.Lock()
        self.feedback_ = None  # action feedback of the running call
        self.cancels_: dict[str, threading.Event] = {}
        rospy.Service("/pg/infer", Infer, self.on_infer)
        rospy.Service("/pg/grasp_target", GraspTarget, self.on_grasp_target)
        self.action_ = actionlib.ActionServer("/pg/grasp_target_action", GraspTargetAction, self.on_action_goal,
                                              self.on_action_cancel, auto_start=False)
        self.action_.start()
        rospy.loginfo("policy node ready: policy %s%s", self.policy_name, " (dry run)" if self.dry_run else "")

    def _on_scene_resets(self, msg: UInt32) -> None:
        self.scene_resets_ = int(msg.data)

    def _publish_action(self, rec) -> None:
        self.pub_decisions.publish(convert.decision_msg(rec, rospy.Time.now()))
        if self.feedback_ is not None:
            self.feedback_(rec)

    def _visualise(self, rec, shm: StampedHeightmap) -> None:
        target = mask_of(shm.heightmap, rec.target)
        stamp = rospy.Time.from_sec(shm.stamp)
        header = DecisionMsg().header
        header.frame_id, header.stamp = convert.WORLD, stamp
        self.pub_q.publish(image_msg(convert.overlay(shm.heightmap, target, rec, self.loop.last_q), "rgb8",
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

    def _call(self, req, cancelled=None, feedback=None) -> dict:
        """The fields of a GraspTarget answer (service response or action result) for one call; `req` has target,
        max_actions, max_failed_grasps and timeout; feedback(rec) is called after every executed action."""
        if self.dry_run:
            return {"success": False, "message": "dry run: this node executes nothing"}
        if not self.busy.acquire(blocking=False):
            return {"success": False, "message": BUSY}
        self.feedback_ = feedback
        try:
            try:
                limits = request_limits(req.max_actions, req.max_failed_grasps, req.timeout, self.limits)
            except ValueError as exc:
                return {"success": False, "message": f"invalid request, nothing moved: {exc}"}
            res = self.loop.run(req.target, limits, cancelled)
        except (LoopError, ValueError) as exc:
            return {"success": False, "message": str(exc)}
        finally:
            self.feedback_ = None
            self.busy.release()
        rospy.loginfo("grasp_target %s: %s [%s] (%d grasps, %d pushes, %.1f s)", req.target or "green",
                      res.message, res.termination, res.grasps, res.pushes, res.duration)
        stamp = rospy.Time.now()
        return {"termination": res.termination, "success": res.success, "grasps": res.grasps, "pushes": res.pushes,
                "duration": res.duration, "wall_time": res.wall_time, "message": res.message,
                "decisions": [convert.decision_msg(r, stamp) for r in res.actions]}

    def on_grasp_target(self, req) -> GraspTargetResponse:
        answer = self._call(req)
        answer.pop("termination", None)  # the message says it in words ("target lost: ...", "cancelled", ...)
        return GraspTargetResponse(**answer)

    def on_action_goal(self, handle) -> None:
        """Accept a goal unless busy (rejected: "busy"), then run it in its own thread; cancel between actions."""
        if self.dry_run or self.busy.locked():
            why = "dry run: this node executes nothing" if self.dry_run else BUSY
            handle.set_rejected(GraspTargetResult(success=False, message=why), why)
            return
        handle.set_accepted()
        threading.Thread(target=self._run_goal, args=(handle,), daemon=True).start()

    def _run_goal(self, handle) -> None:
        cancel = threading.Event()
        self.cancels_[handle.get_goal_id().id] = cancel
        counts = {"grasp": 0, "push": 0}

        def feedback(rec) -> None:
            if rec.execution is not None and rec.execution.success:
                counts[rec.decision.primitive] += 1
            handle.publish_feedback(GraspTargetFeedback(last=convert.decision_msg(rec, rospy.Time.now()),
                                                        grasps=counts["grasp"], pushes=counts["push"]))

        try:
            answer = self._call(handle.get_goal(), cancel.is_set, feedback)
            termination = answer.pop("termination", "")
            result = GraspTargetResult(**answer)
        finally:
            self.cancels_.pop(handle.get_goal_id().id, None)
        if termination == CANCELLED:
            handle.set_canceled(result, "cancelled")
        elif result.success:
            handle.set_succeeded(result, result.message)
        else:
            handle.set_aborted(result, result.message)

    def on_action_cancel(self, handle) -> None:
        event = self.cancels_.get(handle.get_goal_id().id)
        if event is not None:
            event.set()

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
                    rec = self.loop.infer_on(target, shm)  # nothing was executed: no memory of earlier decisions
                except LoopError as exc:
                    rospy.logwarn_throttle(5.0, str(exc))
                    continue
            self._publish_action(rec)


def main() -> None:
    rospy.init_node("pg_policy")
    try:
        node = PolicyNode()
    except (FileNotFoundError, ValueError, RuntimeError, TypeError, ImportError, AttributeError) as exc:
        rospy.logfatal("policy node cannot start: %s", exc)
        sys.exit(1)
    if node.dry_run:
        node.spin_dry_run(str(rospy.get_param("~target", "green")))
    else:
        rospy.spin()
