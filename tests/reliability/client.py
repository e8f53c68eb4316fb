"""The suite's ROS client: service calls bounded in wall time (a frozen node must never stall the suite), a watch on
the arms' command topics (did anything move?), and the simulator's ground truth. Wall clocks only: with /use_sim_time
ROS time stops when the simulator is frozen."""

from __future__ import annotations

import math
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import rospy
from geometry_msgs.msg import PointStamped
from pg_msgs.msg import SceneState
from pg_msgs.srv import (
    ExecutePrimitive,
    ExecutePrimitiveRequest,
    GraspTarget,
    GraspTargetRequest,
    Infer,
    InferRequest,
    ResetScene,
)
from sensor_msgs.msg import Image
from std_msgs.msg import Float64
from trajectory_msgs.msg import JointTrajectory

ARMS = ("left", "right")
CENTRE_GRASP = (0.0, 0.0, 0.02)  # a reachable grasp point at the workspace centre (world, m)
_initialised = False


def init(name: str = "pg_reliability") -> None:
    """Initialise this process's ROS node once (ROS_MASTER_URI etc. must be set in os.environ before)."""
    global _initialised
    if not _initialised:
        rospy.init_node(name, anonymous=True, disable_signals=True, log_level=rospy.WARN)
        _initialised = True


def shutdown() -> None:
    if _initialised:
        rospy.signal_shutdown("reliability suite done")


@dataclass
class Outcome:
    """A bounded call: its answer (or exception), wall seconds, and whether it answered at all within the wait."""

    value: Any = None
    error: str | None = None
    seconds: float = math.nan
    answered: bool = False

    def get(self, name: str, default: Any = None) -> Any:
        return getattr(self.value, name, default) if self.value is not None else default

    @property
    def success(self) -> bool:
        return bool(self.get("success", False))

    @property
    def message(self) -> str:
        if self.value is None:
            return f"<no answer: {self.error}>" if self.error else "<no answer>"
        return str(self.get("message", ""))


def bounded(fn: Callable[[], Any], wait_s: float) -> Outcome:
    """Run fn() in a daemon thread and wait at most wait_s for it (it is left running if it does not return)."""
    out = Outcome()
    done = threading.Event()

    def run() -> None:
        t0 = time.monotonic()
        try:
            out.value = fn()
        except Exception as exc:  # noqa: BLE001 (a failed call is a result, reported)
            out.error = f"{type(exc).__name__}: {exc}"[:500]
        out.seconds = time.monotonic() - t0
        done.set()

    threading.Thread(target=run, daemon=True).start()
    out.answered = done.wait(wait_s)
    if not out.answered:
        out.seconds = wait_s
    return out


class Services:
    """Proxies of the stack's services (looked up at every call, so a restarted node is found again). `policy_ns`:
    where the policy node's grasp_target and infer are served ("/pg"; another policy node's remapped names)."""

    def __init__(self, policy_ns: str = "/pg") -> None:
        self.grasp = rospy.ServiceProxy(f"{policy_ns}/grasp_target", GraspTarget)
        self.infer = rospy.ServiceProxy(f"{policy_ns}/infer", Infer)
        self.reset = rospy.ServiceProxy("/pg_sim/reset_scene", ResetScene)
        self.execute = rospy.ServiceProxy("/pg/execute_primitive", ExecutePrimitive)

    def grasp_target(self, wait_s: float, target: str = "green", max_actions: int = 0, max_failed_grasps: int = 0,
                     timeout: float = 0.0, point: PointStamped | None = None, mask: Image | None = None) -> Outcome:
        req = GraspTargetRequest(target=target, max_actions=max_actions, max_failed_grasps=max_failed_grasps,
                                 timeout=timeout)
        if point is not None:
            req.point = point
        if mask is not None:
            req.mask = mask
        return bounded(lambda: self.grasp(req), wait_s)

    def infer_(self, wait_s: float, target: str = "green", point: PointStamped | None = None,
               mask: Image | None = None) -> Outcome:
        req = InferRequest(target=target)
        if point is not None:
            req.point = point
        if mask is not None:
            req.mask = mask
        return bounded(lambda: self.infer(req), wait_s)

    def reset_scene(self, wait_s: float, scene: str, num_objects: int = 0, seed: int = 0) -> Outcome:
        return bounded(lambda: self.reset(scene=scene, num_objects=num_objects, seed=seed), wait_s)

    def execute_primitive(self, wait_s: float, primitive: int, position: tuple[float, float, float], frame: str,
                          yaw: float = 0.0, arm: str = "", timeout: float = 0.0) -> Outcome:
        req = ExecutePrimitiveRequest(primitive=primitive, yaw=yaw, arm=arm, timeout=timeout)
        req.position.header.frame_id = frame
        req.position.point.x, req.position.point.y, req.position.point.z = position
        return bounded(lambda: self.execute(req), wait_s)

    def wait_idle(self, wait_s: float = 120.0) -> bool:
        """Until /pg/infer answers without "busy" (a call the suite gave up on may still run), bounded."""
        deadline = time.monotonic() + wait_s
        while time.monotonic() < deadline:
            out = self.infer_(10.0)
            if out.answered and out.value is not None and "busy" not in out.message:
                return True
            time.sleep(1.0)
        return False


@dataclass
class MotionWatch:
    """Counts messages on both arms' trajectory and gripper command topics (what the controller sends to move)."""

    counts: dict[str, int] = field(default_factory=dict)
    subs: list[rospy.Subscriber] = field(default_factory=list)
    lock: threading.Lock = field(default_factory=threading.Lock)

    def start(self) -> MotionWatch:
        for arm in ARMS:
            for topic, kind in ((f"/{arm}/scaled_pos_joint_traj_controller/command", JointTrajectory),
                                (f"/{arm}/gripper/command", Float64)):
                self.counts[topic] = 0
                self.subs.append(rospy.Subscriber(topic, kind, self._on, callback_args=topic, queue_size=100))
        return self

    def _on(self, _msg: Any, topic: str) -> None:
        with self.lock:
            self.counts[topic] += 1

    def total(self) -> int:
        with self.lock:
            return sum(self.counts.values())

    def settle(self, quiet_s: float = 0.3, wait_s: float = 3.0) -> int:
        """Let in-flight messages arrive: wait until the count has not changed for quiet_s (bounded); the total."""
        deadline = time.monotonic() + wait_s
        last = self.total()
        while time.monotonic() < deadline:
            time.sleep(quiet_s)
            now = self.total()
            if now == last:
                return now
            last = now
        return last

    def stop(self) -> None:
        for s in self.subs:
            s.unregister()
        self.subs.clear()


def scene_state(wait_s: float = 10.0, newer_than: float | None = None) -> SceneState | None:
    """The latest /pg_sim/scene_state (stamped after `newer_than`, sim seconds, when given), None within wait_s."""
    deadline = time.monotonic() + wait_s
    while time.monotonic() < deadline:
        try:
            msg = rospy.wait_for_message("/pg_sim/scene_state", SceneState,
                                         timeout=max(0.1, deadline - time.monotonic()))
        except rospy.ROSException:
            return None
        if newer_than is None or msg.header.stamp.to_sec() > newer_than:
            return msg
        time.sleep(0.1)
    return None


def fresh_scene_state(wait_s: float = 10.0) -> SceneState | None:
    """The first /pg_sim/scene_state stamped after this call began (so after any reset answered before it)."""
    return scene_state(wait_s, newer_than=rospy.get_time())


def poses(state: SceneState | None) -> dict[str, tuple[float, float, float]]:
    if state is None:
        return {}
    return {o.name: (o.pose.position.x, o.pose.position.y, o.pose.position.z) for o in state.objects}


def max_displacement(a: SceneState | None, b: SceneState | None) -> float:
    """Largest position change (m) of an object present in both snapshots; inf when either is missing."""
    pa, pb = poses(a), poses(b)
    common = set(pa) & set(pb)
    if a is None or b is None or not common:
        return math.inf
    return max(math.dist(pa[n], pb[n]) for n in common)


def same_scene(a: SceneState | None, b: SceneState | None, tol_m: float = 0.01) -> bool:
    """Same scene name, same objects, none moved by more than tol_m."""
    return (a is not None and b is not None and a.scene == b.scene and set(poses(a)) == set(poses(b))
            and max_displacement(a, b) <= tol_m)


STATE_NAMES = {0: "PENDING", 1: "ACTIVE", 2: "PREEMPTED", 3: "SUCCEEDED", 4: "ABORTED", 5: "REJECTED",
               6: "PREEMPTING", 7: "RECALLING", 8: "RECALLED", 9: "LOST"}


class GraspAction:
    """Client of /pg/grasp_target_action with wall-clock waits; close() unregisters its topics. Built on actionlib's
    ActionClient: the simple client drops a transition that arrives before send_goal has returned (a goal rejected at
    once), which would read as a goal never answered."""

    def __init__(self) -> None:
        import actionlib
        from pg_msgs.msg import GraspTargetAction

        self.client = actionlib.ActionClient("/pg/grasp_target_action", GraspTargetAction)

    def ready(self, wait_s: float = 15.0) -> bool:
        deadline = time.monotonic() + wait_s
        while time.monotonic() < deadline:
            if self.client.last_status_msg is not None and self.client.pub_goal.get_num_connections() > 0:
                return True
            time.sleep(0.1)
        return False

    def send(self, wait_s: float, target: str = "green", max_actions: int = 0, max_failed_grasps: int = 0,
             timeout: float = 0.0) -> tuple[Outcome, str]:
        """Send a goal and wait (wall time) until it is done; (outcome with the result, final state name). A goal not
        done within wait_s is cancelled and reported unanswered."""
        from actionlib import CommState
        from pg_msgs.msg import GraspTargetGoal

        goal = GraspTargetGoal(target=target, max_actions=max_actions, max_failed_grasps=max_failed_grasps,
                               timeout=timeout)
        out = Outcome()
        done = threading.Event()
        last: dict[str, Any] = {}

        def on_transition(handle: Any) -> None:
            last["status"] = handle.get_goal_status()
            if handle.get_comm_state() == CommState.DONE:
                last["result"] = handle.get_result()
                done.set()

        t0 = time.monotonic()
        try:
            handle = self.client.send_goal(goal, on_transition)
        except Exception as exc:  # noqa: BLE001 (reported)
            out.error = f"{type(exc).__name__}: {exc}"
            return out, "NOT SENT"
        out.answered = done.wait(wait_s)
        out.seconds = time.monotonic() - t0
        out.value = last.get("result")
        state = STATE_NAMES.get(last.get("status", 0), str(last.get("status")))
        if not out.answered:
            handle.cancel()
        return out, state

    def close(self) -> None:
        c = self.client
        for part in (c.pub_goal, c.pub_cancel, c.status_sub, c.result_sub, c.feedback_sub):
            part.unregister()
