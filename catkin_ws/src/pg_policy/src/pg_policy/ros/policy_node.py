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
Targets (pg_policy.ros.target_io): ~tf_timeout (0.5 wall s per tf2 lookup of a point's or a mask's frame),
~camera_info_topic ("/camera/color/camera_info": the size, intrinsics and frame masks must match), ~mask_max_skew
(2.0 s of ROS time between a mask's stamp and the heightmap it is projected with), ~click_to_grasp (false: true
subscribes to ~clicked_point_topic, "/clicked_point", geometry_msgs/PointStamped as rviz's "Publish Point" tool
sends it; each click runs a grasp_target call on that point, refused clicks, "busy" included, are logged with the
reason).
A missing or corrupt model file, or a limit parameter out of range, ends the node at start-up with the reason (exit
status 1). A request with a negative max_actions / max_failed_grasps or a NaN, infinite or negative timeout, or a
target it cannot take (two forms set, a point off the workspace, on bare table or in a frame tf2 cannot reach, a
mask empty, all zero, of another encoding or size, or stamped too far from the heightmap) is refused with a message
naming the field; nothing moves. A target name repeated in an answer or a log line is cut
to pg_core.user_text.ECHOED_CHARS characters. The answer's message says why a call ended (the episode
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
from geometry_msgs.msg import PointStamped
from pg_msgs.msg import Decision as DecisionMsg
from pg_msgs.msg import GraspTargetAction, GraspTargetFeedback, GraspTargetResult
from pg_msgs.srv import GraspTarget, GraspTargetRequest, GraspTargetResponse, Infer, InferResponse
from sensor_msgs.msg import Image
from std_msgs.msg import UInt32
from visualization_msgs.msg import MarkerArray

from pg_conversions.heightmap_msg import image_msg
from pg_core.geometry import load as load_geometry
from pg_core.user_text import cut
from pg_policy.policies import options
from pg_policy.policies.policy import PolicyOptions
from pg_policy.policies.registry import make_policy
from pg_policy.ros import convert
from pg_policy.ros.loop_io import ServiceExecutor, TopicHeightmapSource
from pg_policy.ros.target_io import TargetRequests
from pg_policy.ros.target_request import first_view_field, refusal
from pg_policy.target_loop.episode import CANCELLED, DEFAULT_MAX_ACTIONS, DEFAULT_MAX_FAILED_GRASPS
from pg_policy.target_loop.loop_limits import DEFAULT_TIMEOUT_S, LoopLimits, request_limits
from pg_policy.target_loop.loop_types import (
    LoopError,
    NoHeightmap,
    StampedHeightmap,
    TargetRefused,
    as_spec,
    mask_of,
    target_label,
)
from pg_policy.target_loop.target_loop import TargetLoop

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
        self.targets = TargetRequests(self.source, load_geometry().workspace.bounds,
                                      str(rospy.get_param("~camera_info_topic", "/camera/color/camera_info")),
                                      float(rospy.get_param("~tf_timeout", 0.5)),
                                      float(rospy.get_param("~mask_max_skew", 2.0)),
                                      float(rospy.get_param("~heightmap_timeout", 5.0)))
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
                               on_decision=self._visualise, scene_epoch=lambda: self.scene_resets_,
                               segmenter=str(rospy.get_param("~segmenter", "none")))
        self.busy = threading.Lock()
        self.feedback_ = None  # action feedback of the running call
        self.cancels_: dict[str, threading.Event] = {}
        rospy.Service("/pg/infer", Infer, self.on_infer)
        rospy.Service("/pg/grasp_target", GraspTarget, self.on_grasp_target)
        self.action_ = actionlib.ActionServer("/pg/grasp_target_action", GraspTargetAction, self.on_action_goal,
                                              self.on_action_cancel, auto_start=False)
        self.action_.start()
        self.sub_clicks_ = None
        if bool(rospy.get_param("~click_to_grasp", False)):
            topic = str(rospy.get_param("~clicked_point_topic", "/clicked_point"))
            self.sub_clicks_ = rospy.Subscriber(topic, PointStamped, self._on_click, queue_size=1)
            rospy.loginfo("click to grasp: a point on %s starts a grasp_target call", topic)
        rospy.loginfo("policy node ready: policy %s%s", self.policy_name, " (dry run)" if self.dry_run else "")

    def _on_scene_resets(self, msg: UInt32) -> None:
        self.scene_resets_ = int(msg.data)

    def _publish_action(self, rec) -> None:
        self.pub_decisions.publish(convert.decision_msg(rec, rospy.Time.now()))
        if self.feedback_ is not None:
            self.feedback_(rec)

    def _visualise(self, rec, shm: StampedHeightmap) -> None:
        target = rec.target_mask if rec.target_mask is not None else mask_of(shm.heightmap, rec.target)
        stamp = rospy.Time.from_sec(shm.stamp)
        header = DecisionMsg().header
        header.frame_id, header.stamp = convert.WORLD, stamp
        self.pub_q.publish(image_msg(convert.overlay(shm.heightmap, target, rec, self.loop.last_q), "rgb8",
                                             header))
        self.pub_markers.publish(convert.markers(shm.heightmap, target, rec, stamp))

    def on_infer(self, req) -> InferResponse:
        if not self.busy.acquire(blocking=False):
            return InferResponse(success=False, message="busy: a grasp_target call is running")
        form = "target"
        try:
            form, target = self.targets.target(req)
            rec = self.loop.infer(target)
            return InferResponse(success=True, message="ok", decision=convert.decision_msg(rec, rospy.Time.now()))
        except TargetRefused as exc:
            return InferResponse(success=False, message=refusal(first_view_field(form, str(exc))))
        except ValueError as exc:
            return InferResponse(success=False, message=refusal(str(exc)))
        except LoopError as exc:
            return InferResponse(success=False, message=str(exc))
        finally:
            self.busy.release()

    def _call(self, req, cancelled=None, feedback=None) -> dict:
        """The fields of a GraspTarget answer (service response or action result) for one call; `req` has target,
        point, mask, max_actions, max_failed_grasps and timeout; feedback(rec) is called after every executed
        action."""
        if self.dry_run:
            return {"success": False, "message": "dry run: this node executes nothing"}
        if not self.busy.acquire(blocking=False):
            return {"success": False, "message": BUSY}
        self.feedback_ = feedback
        form, label = "target", cut(req.target or "green")
        try:
            try:
                limits = request_limits(req.max_actions, req.max_failed_grasps, req.timeout, self.limits)
                form, target = self.targets.target(req)
                label = cut(target_label(as_spec(target)))
            except ValueError as exc:
                return {"success": False, "message": refusal(str(exc))}
            res = self.loop.run(target, limits, cancelled)
        except TargetRefused as exc:
            return {"success": False, "message": refusal(first_view_field(form, str(exc)))}
        except (LoopError, ValueError) as exc:
            return {"success": False, "message": str(exc)}
        finally:
            self.feedback_ = None
            self.busy.release()
        rospy.loginfo("grasp_target %s: %s [%s] (%d grasps, %d pushes, %.1f s)", label,
                      res.message, res.termination, res.grasps, res.pushes, res.duration)
        stamp = rospy.Time.now()
        return {"termination": res.termination, "success": res.success, "grasps": res.grasps, "pushes": res.pushes,
                "duration": res.duration, "wall_time": res.wall_time, "message": res.message,
                "decisions": [convert.decision_msg(r, stamp) for r in res.actions]}

    def on_grasp_target(self, req) -> GraspTargetResponse:
        answer = self._call(req)
        answer.pop("termination", None)  # the message says it in words ("target lost: ...", "cancelled", ...)
        return GraspTargetResponse(**answer)

    def _on_click(self, msg: PointStamped) -> None:
        """A click (rviz "Publish Point"): a grasp_target call on that point in its own thread; "busy" while one
        runs."""
        if self.dry_run or self.busy.locked():
            rospy.logwarn("click at (%.3f, %.3f, %.3f) in '%s' refused: %s", msg.point.x, msg.point.y, msg.point.z,
                          cut(msg.header.frame_id), "dry run" if self.dry_run else BUSY)
            return
        threading.Thread(target=self._run_click, args=(msg,), daemon=True).start()

    def _run_click(self, msg: PointStamped) -> None:
        answer = self._call(GraspTargetRequest(point=msg))
        log = rospy.loginfo if answer.get("success") else rospy.logwarn
        log("click at (%.3f, %.3f, %.3f) in '%s': %s", msg.point.x, msg.point.y, msg.point.z,
            cut(msg.header.frame_id), answer.get("message", ""))

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
