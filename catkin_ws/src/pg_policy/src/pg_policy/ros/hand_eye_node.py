"""hand_eye_calibration: collects views of the ChArUco board on the tool and solves the camera pose in `world`
(launch/calibrate.launch), the arm driven through planned poses (`~run`) or moved by hand (`~capture`).

Services (std_srvs/Trigger):
- `~run` drives `~arm` from its present joints through up to `~poses` board poses above the workspace
  (pg_core.calibration_poses: reachable, every joint motion keeps the arm 8 cm above the table), captures a view
  at each after `~settle_s`, returns the arm to where it started, then solves and writes `~out` like `~solve`. The
  views kept before are dropped. Each move is one joint trajectory on `~trajectory_topic` at `~max_joint_speed`,
  done when every joint is within `~joint_tolerance` of its target, failed after its duration x 3 + 5 s (wall):
  the tour then stops and the arm is sent back. The answer says how many poses and views, and the residuals.
- `~capture` takes the latest colour image (and aligned depth, when published), the tool pose world <- `~tool_frame`
  from tf at the image's stamp, and detects the board: the answer says how many corners it found and how many views
  are kept (for an arm moved by hand: teach pendant, freedrive).
- `~solve` runs pg_policy.perception.hand_eye on the kept views, fits the depth scale and offset, and writes `~out`
  (nothing is written when it fails; the answer says why).
Parameters: ~tool_frame (left_tool0), ~arm (the tool frame's prefix: left), ~world_frame (world), ~out
(camera_calibration.yaml in the working directory), ~min_views (6), ~wait_s (2.0: the longest wait for an image,
a transform or joint states), ~poses (12), ~max_joint_speed (0.5 rad/s), ~settle_s (1.0 s of ROS time),
~joint_tolerance (0.01 rad), ~trajectory_topic ("/{arm}/scaled_pos_joint_traj_controller/command").
Topics: /camera/color/image_raw (rgb8 or bgr8), /camera/color/camera_info (K),
/camera/aligned_depth_to_color/image_raw (32FC1 m or 16UC1 mm, optional), /joint_states (joints `<arm>_<joint>`).
"""

from __future__ import annotations

import threading
import time
from typing import Any

import numpy as np
import rospy
import tf2_ros
from sensor_msgs.msg import CameraInfo, Image, JointState
from std_srvs.srv import Trigger, TriggerResponse
from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint

from pg_core.calibration_poses import calibration_plan
from pg_core.geometry import load
from pg_core.user_text import cut
from pg_policy.perception.calibration_tour import TourAborted, run_tour
from pg_policy.perception.charuco import DEFAULT_BOARD, detect
from pg_policy.perception.hand_eye import (
    MIN_VIEWS,
    CalibrationFailed,
    View,
    depth_pairs,
    fit_depth,
    solve,
    summary,
    write_calibration,
)


def image_array(msg: Any) -> np.ndarray:
    """(H, W, 3) uint8 RGB of an rgb8/bgr8 Image, or (H, W) float32 m of a 32FC1 / 16UC1 (mm) depth Image."""
    kinds = {"rgb8": (np.uint8, 3), "bgr8": (np.uint8, 3), "32FC1": (np.float32, 1), "16UC1": (np.uint16, 1)}
    if msg.encoding not in kinds:
        raise ValueError(f"image encoding {msg.encoding!r}: expected one of {', '.join(kinds)}")
    dtype, ch = kinds[msg.encoding]
    row = np.frombuffer(msg.data, dtype=np.dtype(dtype).newbyteorder(">" if msg.is_bigendian else "<"))
    arr = row.reshape(msg.height, msg.step // np.dtype(dtype).itemsize)[:, : msg.width * ch]
    arr = arr.reshape(msg.height, msg.width, ch) if ch == 3 else arr
    if msg.encoding == "bgr8":
        return np.ascontiguousarray(arr[:, :, ::-1])
    if msg.encoding == "16UC1":
        return arr.astype(np.float32) / 1000.0
    return np.array(arr, dtype=np.float32 if ch == 1 else np.uint8)


def transform_matrix(t: Any) -> np.ndarray:
    """4x4 of a geometry_msgs/Transform."""
    from scipy.spatial.transform import Rotation

    m = np.eye(4)
    q = t.rotation
    m[:3, :3] = Rotation.from_quat([q.x, q.y, q.z, q.w]).as_matrix()
    m[:3, 3] = [t.translation.x, t.translation.y, t.translation.z]
    return m


class HandEyeSession:
    """The views kept so far and the solution (ROS-free): `add` one view, `solve` them into a calibration file."""

    def __init__(self, k: np.ndarray | None = None, min_views: int = MIN_VIEWS) -> None:
        self.k = k
        self.min_views = min_views
        self.views: list[View] = []
        self.missed: list[View] = []  # captures that showed fewer than 6 corners (counted in a refusal)

    def add(self, world_tool: np.ndarray, color: np.ndarray, depth: np.ndarray | None) -> int:
        """Detect the board in `color` and keep the view when it shows >= 6 corners; returns the corners found."""
        det = detect(DEFAULT_BOARD, color)
        (self.views if len(det.ids) >= 6 else self.missed).append(View(world_tool, det, depth))
        return len(det.ids)

    def solve(self, out: str) -> str:
        """Solve, write `out`, and return the summary; raises CalibrationFailed (nothing written)."""
        if self.k is None:
            raise CalibrationFailed("no camera_info received: the intrinsics are unknown")
        result = solve(self.views + self.missed, DEFAULT_BOARD, self.k, self.min_views)
        table = next((v.depth for v in self.views if v.depth is not None), None)
        depth = fit_depth(depth_pairs(result, self.views, table, self.k, DEFAULT_BOARD)) if table is not None else None
        write_calibration(out, result, depth)
        return f"wrote {out}: {summary(result, depth)}"


class ArmMover:
    """Moves one arm by joint trajectories and watches /joint_states (names `<arm>_<joint>`); see `~run`."""

    def __init__(self, arm: str, joint_names: tuple[str, ...], topic: str, speed: float, tolerance: float) -> None:
        self.names = tuple(f"{arm}_{j}" for j in joint_names)
        self.speed, self.tolerance = speed, tolerance
        self.pub = rospy.Publisher(topic, JointTrajectory, queue_size=1)
        self.lock = threading.Lock()
        self.latest: np.ndarray | None = None
        rospy.Subscriber("/joint_states", JointState, self._on_joints, queue_size=10)

    def _on_joints(self, msg: Any) -> None:
        index = {n: i for i, n in enumerate(msg.name)}
        if all(n in index for n in self.names):
            with self.lock:
                self.latest = np.array([msg.position[index[n]] for n in self.names], dtype=np.float64)

    def joints(self, wait: float) -> np.ndarray | None:
        """The arm's latest joint positions (rad), waiting up to `wait` s (wall) for a first message."""
        deadline = time.monotonic() + wait
        while time.monotonic() < deadline and not rospy.is_shutdown():
            with self.lock:
                if self.latest is not None:
                    return self.latest.copy()
            time.sleep(0.02)
        return None

    def move(self, q: np.ndarray) -> str | None:
        """One straight joint-space trajectory to `q`; None once every joint is within tolerance, else why not."""
        now = self.joints(1.0)
        if now is None:
            return "no joint states on /joint_states"
        duration = max(float(np.abs(q - now).max()) / self.speed, 0.5)
        msg = JointTrajectory(joint_names=list(self.names))
        msg.points = [JointTrajectoryPoint(positions=now.tolist(), velocities=[0.0] * len(q),
                                           time_from_start=rospy.Duration(0.0)),
                      JointTrajectoryPoint(positions=np.asarray(q).tolist(), velocities=[0.0] * len(q),
                                           time_from_start=rospy.Duration(duration))]
        self.pub.publish(msg)  # header stamp 0: start on receipt
        deadline = time.monotonic() + 3.0 * duration + 5.0
        while time.monotonic() < deadline and not rospy.is_shutdown():
            got = self.joints(0.5)
            if got is not None and float(np.abs(got - q).max()) <= self.tolerance:
                return None
            time.sleep(0.05)
        got = self.joints(0.0)
        off = "unknown" if got is None else f"{float(np.abs(got - q).max()):.3f} rad"
        return f"the arm did not reach its target within {3.0 * duration + 5.0:.0f} s (largest joint error {off})"


def main() -> None:
    rospy.init_node("hand_eye_calibration")
    tool, world = rospy.get_param("~tool_frame", "left_tool0"), rospy.get_param("~world_frame", "world")
    out, wait = rospy.get_param("~out", "camera_calibration.yaml"), float(rospy.get_param("~wait_s", 2.0))
    min_views = int(rospy.get_param("~min_views", MIN_VIEWS))
    session = HandEyeSession(min_views=min_views)
    arm = str(rospy.get_param("~arm", tool.split("_tool0")[0]))
    geometry = load()
    if arm not in geometry.robot.arms:
        rospy.logfatal(f"hand_eye_calibration: ~arm {cut(arm, quoted=True)} is not an arm of the workspace "
                       f"({', '.join(geometry.robot.arms)})")
        raise SystemExit(1)
    mover = ArmMover(arm, geometry.robot.joint_names,
                     str(rospy.get_param("~trajectory_topic", "/{arm}/scaled_pos_joint_traj_controller/command"))
                     .format(arm=arm), float(rospy.get_param("~max_joint_speed", 0.5)),
                     float(rospy.get_param("~joint_tolerance", 0.01)))
    poses, settle = int(rospy.get_param("~poses", 12)), float(rospy.get_param("~settle_s", 1.0))
    latest: dict[str, Any] = {}
    lock = threading.Lock()
    busy = threading.Lock()

    def keep(key: str) -> Any:
        def cb(msg: Any) -> None:
            with lock:
                latest[key] = msg
        return cb

    tf_buffer = tf2_ros.Buffer(cache_time=rospy.Duration(30.0))
    tf2_ros.TransformListener(tf_buffer)
    rospy.Subscriber("/camera/color/image_raw", Image, keep("color"), queue_size=1, buff_size=2 ** 24)
    rospy.Subscriber("/camera/aligned_depth_to_color/image_raw", Image, keep("depth"), queue_size=1,
                     buff_size=2 ** 24)
    rospy.Subscriber("/camera/color/camera_info", CameraInfo, keep("info"), queue_size=1)

    def capture_view() -> tuple[bool, str]:
        asked = rospy.Time.now()
        deadline = time.monotonic() + wait
        while time.monotonic() < deadline and not rospy.is_shutdown():  # an image taken after the request
            with lock:
                color, depth, info = latest.get("color"), latest.get("depth"), latest.get("info")
            if color is not None and color.header.stamp >= asked:
                break
            time.sleep(0.02)
        else:
            return False, f"no colour image newer than the request within {wait:g} s"
        if info is not None:
            session.k = np.asarray(info.K, dtype=np.float64).reshape(3, 3)
        try:
            t = tf_buffer.lookup_transform(world, tool, color.header.stamp, rospy.Duration(wait))
        except (tf2_ros.LookupException, tf2_ros.ExtrapolationException, tf2_ros.ConnectivityException) as exc:
            return False, f"no transform {world} <- {tool} at the image's stamp: {exc}"
        found = session.add(transform_matrix(t.transform), image_array(color),
                            image_array(depth) if depth is not None else None)
        return found >= 6, f"{found} corners; {len(session.views)} views kept"

    def capture(_: Any) -> TriggerResponse:
        if not busy.acquire(blocking=False):
            return TriggerResponse(False, "busy: a ~run is driving the arm")
        try:
            return TriggerResponse(*capture_view())
        finally:
            busy.release()

    def solve_cb(_: Any) -> TriggerResponse:
        try:
            return TriggerResponse(True, session.solve(out))
        except (CalibrationFailed, OSError) as exc:
            return TriggerResponse(False, str(exc))

    def settled_capture() -> tuple[bool, str]:
        end = time.monotonic() + 10.0 * settle + 5.0  # ROS time may run slower than the wall clock
        target = rospy.get_time() + settle
        while rospy.get_time() < target and time.monotonic() < end and not rospy.is_shutdown():
            time.sleep(0.02)
        return capture_view()

    def run_cb(_: Any) -> TriggerResponse:
        if not busy.acquire(blocking=False):
            return TriggerResponse(False, "busy: a ~run is driving the arm")
        try:
            start = mover.joints(wait)
            if start is None:
                return TriggerResponse(False, f"no joint states of the {arm} arm on /joint_states within {wait:g} s")
            plan = calibration_plan(geometry, arm, start, poses)
            if len(plan) < min_views:
                return TriggerResponse(False, f"only {len(plan)} of {poses} board poses are reachable from the "
                                              f"{arm} arm's present joints with a clear path; {min_views} are "
                                              "needed: nothing moved")
            session.views.clear()
            session.missed.clear()
            try:
                report = run_tour(plan, start, mover.move, settled_capture,
                                  lambda line: rospy.loginfo(f"hand_eye_calibration: {line}"))
            except TourAborted as exc:
                return TriggerResponse(False, f"stopped: {exc}; nothing written")
            try:
                return TriggerResponse(True, f"{report.summary()}; {session.solve(out)}")
            except (CalibrationFailed, OSError) as exc:
                return TriggerResponse(False, f"{report.summary()}; {exc}")
        finally:
            busy.release()

    rospy.Service("~run", Trigger, run_cb)
    rospy.Service("~capture", Trigger, capture)
    rospy.Service("~solve", Trigger, solve_cb)
    rospy.loginfo("hand_eye_calibration: call ~run to drive the %s arm through %d board poses, or move the board "
                  "(on %s) by hand and call ~capture at 8-15 poses, then ~solve", arm, poses, tool)
    rospy.spin()
