"""hand_eye_calibration: collects views of the ChArUco board on the tool while the arm is moved by hand (teach
pendant, freedrive), and solves the camera pose in `world` (launch/calibrate.launch). It commands no motion.

Services (std_srvs/Trigger): `~capture` takes the latest colour image (and aligned depth, when published), the tool
pose world <- `~tool_frame` from tf at the image's stamp, and detects the board: the answer says how many corners it
found and how many views are kept. `~solve` runs pg_policy.perception.hand_eye on the kept views, fits the depth
scale and offset, and writes `~out` (nothing is written when it fails; the answer says why).
Parameters: ~tool_frame (left_tool0), ~world_frame (world), ~out (camera_calibration.yaml in the working
directory), ~min_views (6), ~wait_s (2.0: the longest wait for an image or a transform).
Topics: /camera/color/image_raw (rgb8 or bgr8), /camera/color/camera_info (K),
/camera/aligned_depth_to_color/image_raw (32FC1 m or 16UC1 mm, optional).
"""

from __future__ import annotations

import threading
from typing import Any

import numpy as np
import rospy
import tf2_ros
from sensor_msgs.msg import CameraInfo, Image
from std_srvs.srv import Trigger, TriggerResponse

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

    def add(self, world_tool: np.ndarray, color: np.ndarray, depth: np.ndarray | None) -> int:
        """Detect the board in `color` and keep the view when it shows >= 6 corners; returns the corners found."""
        det = detect(DEFAULT_BOARD, color)
        if len(det.ids) >= 6:
            self.views.append(View(world_tool, det, depth))
        return len(det.ids)

    def solve(self, out: str) -> str:
        """Solve, write `out`, and return the summary; raises CalibrationFailed (nothing written)."""
        if self.k is None:
            raise CalibrationFailed("no camera_info received: the intrinsics are unknown")
        result = solve(self.views, DEFAULT_BOARD, self.k, self.min_views)
        table = next((v.depth for v in self.views if v.depth is not None), None)
        depth = fit_depth(depth_pairs(result, self.views, table, self.k, DEFAULT_BOARD)) if table is not None else None
        write_calibration(out, result, depth)
        return f"wrote {out}: {summary(result, depth)}"


def main() -> None:
    rospy.init_node("hand_eye_calibration")
    tool, world = rospy.get_param("~tool_frame", "left_tool0"), rospy.get_param("~world_frame", "world")
    out, wait = rospy.get_param("~out", "camera_calibration.yaml"), float(rospy.get_param("~wait_s", 2.0))
    session = HandEyeSession(min_views=int(rospy.get_param("~min_views", MIN_VIEWS)))
    latest: dict[str, Any] = {}
    lock = threading.Lock()

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

    def capture(_: Any) -> TriggerResponse:
        asked = rospy.Time.now()
        deadline = rospy.get_time() + wait
        while rospy.get_time() < deadline and not rospy.is_shutdown():  # an image taken after the request
            with lock:
                color, depth, info = latest.get("color"), latest.get("depth"), latest.get("info")
            if color is not None and color.header.stamp >= asked:
                break
            rospy.sleep(0.02)
        else:
            return TriggerResponse(False, f"no colour image newer than the request within {wait:g} s")
        if info is not None:
            session.k = np.asarray(info.K, dtype=np.float64).reshape(3, 3)
        try:
            t = tf_buffer.lookup_transform(world, tool, color.header.stamp, rospy.Duration(wait))
        except (tf2_ros.LookupException, tf2_ros.ExtrapolationException, tf2_ros.ConnectivityException) as exc:
            return TriggerResponse(False, f"no transform {world} <- {tool} at the image's stamp: {exc}")
        found = session.add(transform_matrix(t.transform), image_array(color),
                            image_array(depth) if depth is not None else None)
        return TriggerResponse(found >= 6, f"{found} corners; {len(session.views)} views kept")

    def solve_cb(_: Any) -> TriggerResponse:
        try:
            return TriggerResponse(True, session.solve(out))
        except (CalibrationFailed, OSError) as exc:
            return TriggerResponse(False, str(exc))

    rospy.Service("~capture", Trigger, capture)
    rospy.Service("~solve", Trigger, solve_cb)
    rospy.loginfo("hand_eye_calibration: move the board (on %s) into view, call ~capture at 8-15 poses, then ~solve",
                  tool)
    rospy.spin()
