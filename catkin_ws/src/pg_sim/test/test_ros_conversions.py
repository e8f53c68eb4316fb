"""pg_sim.ros.ros_conversions: runtime data <-> ROS messages (message classes only; no master, no node).

Needs the ROS message packages and, for the pg_msgs parts, the catkin devel space: without them a "ROS tier:" skip,
which fails unless PG_SKIP_ROS_TIER=1 (conftest.py).
"""

from __future__ import annotations

import io

import numpy as np
import pytest

pytest.importorskip("sensor_msgs.msg", reason="ROS tier: sensor_msgs not importable (make setup installs ROS)")
pytest.importorskip("genpy", reason="ROS tier: genpy not importable (make setup installs ROS)")

from genpy import Duration, Time  # noqa: E402
from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint  # noqa: E402
from visualization_msgs.msg import Marker  # noqa: E402

from pg_core.geometry import load  # noqa: E402
from pg_sim.ros import ros_conversions as conv  # noqa: E402
from pg_sim.runtime.runtime_types import (  # noqa: E402
    CameraCapture,
    JointStateData,
    ObjectState,
    ResetResult,
    SceneState,
)
from pg_sim.scenes.scene import ObjectSpec  # noqa: E402
from pg_sim.world.sensor_data import CloudBuilder, marker_parts, pose_parts  # noqa: E402

FRAME = "camera_color_optical_frame"


def serialized(msg) -> bytes:
    buf = io.BytesIO()
    msg.serialize(buf)
    return buf.getvalue()


def test_camera_messages_share_the_stamp_and_frame():
    cam = load().camera
    depth = np.full((cam.height, cam.width), 0.7, dtype=np.float32)
    depth[0, :5] = np.nan
    color = np.zeros((cam.height, cam.width, 3), dtype=np.uint8)
    color[..., 1] = 200
    cloud = CloudBuilder(cam.intrinsics, cam.width, cam.height).build(depth, color)
    msgs = conv.camera_messages(CameraCapture(12.5, color, depth, cloud, 0, True, 0.0), cam, FRAME)
    assert {m.header.stamp for m in msgs.values()} == {Time(12, 500000000)}
    assert {m.header.frame_id for m in msgs.values()} == {FRAME}
    pc = msgs["depth/color/points"]
    assert (pc.height, pc.width, pc.point_step, pc.row_step) == (480, 640, 16, 640 * 16) and not pc.is_dense
    assert [(f.name, f.offset, f.datatype, f.count) for f in pc.fields] == [
        ("x", 0, 7, 1), ("y", 4, 7, 1), ("z", 8, 7, 1), ("rgb", 12, 7, 1)]
    pts = np.frombuffer(pc.data, dtype=np.float32).reshape(480, 640, 4)
    assert np.isnan(pts[0, :5, :3]).all() and np.allclose(pts[1:, :, 2], 0.7)
    img = msgs["color/image_raw"]
    assert (img.encoding, img.step, len(img.data)) == ("rgb8", 640 * 3, 640 * 480 * 3)
    d = msgs["aligned_depth_to_color/image_raw"]
    assert (d.encoding, d.step, len(d.data)) == ("32FC1", 640 * 4, 640 * 480 * 4)
    info = msgs["color/camera_info"]
    assert list(info.K) == [cam.fx, 0.0, cam.cx, 0.0, cam.fy, cam.cy, 0.0, 0.0, 1.0] and info.width == 640
    assert len(serialized(pc)) > 640 * 480 * 16
    conv.restamp(msgs, 13.0)
    assert {m.header.stamp for m in msgs.values()} == {Time(13, 0)}


def test_trajectory_from_message():
    msg = JointTrajectory(joint_names=["left_elbow_joint", "left_wrist_1_joint"])
    msg.header.stamp = Time(3, 0)
    msg.points = [JointTrajectoryPoint(positions=[0.1, 0.2], time_from_start=Duration(1, 500000000)),
                  JointTrajectoryPoint(positions=[0.3, 0.4], velocities=[0.0, 0.0], time_from_start=Duration(2))]
    t = conv.trajectory(msg)
    assert t.joint_names == ("left_elbow_joint", "left_wrist_1_joint") and t.stamp == 3.0
    assert t.points[0].time_from_start == 1.5 and t.points[0].velocities == ()
    assert t.points[1].positions == (0.3, 0.4) and t.points[1].velocities == (0.0, 0.0)


def test_joint_state_and_clock():
    js = conv.joint_state(JointStateData(2.25, ("a", "b"), np.array([0.1, 0.2]), np.array([0.0, 1.0])))
    assert js.name == ["a", "b"] and js.position == [0.1, 0.2] and js.header.stamp == Time(2, 250000000)
    assert conv.clock(0.5).clock == Time(0, 500000000)


def test_markers_start_with_deleteall_and_carry_the_parts():
    arch = ObjectSpec(shape="arch", size=None, color=(89, 161, 79), pose=(0, 0, 0, 0, 0, 0), name="a")
    cube = ObjectSpec(shape="cube", size=None, color=(255, 0, 0), pose=(0, 0, 0, 0, 0, 0), name="c")
    items = pose_parts("a", marker_parts(arch), np.zeros(3), np.array([0, 0, 0, 1.0]), (0.35, 0.63, 0.31, 1.0))
    items += pose_parts("c", marker_parts(cube), np.array([0.1, 0, 0.02]), np.array([0, 0, 0, 1.0]), (1, 0, 0, 1))
    arr = conv.markers(items, 1.0, "world")
    assert arr.markers[0].action == Marker.DELETEALL
    rest = arr.markers[1:]
    assert len(rest) == len(items) and all(m.header.frame_id == "world" for m in rest)
    assert {m.ns for m in rest} == {"pg_sim_objects/a", "pg_sim_objects/c"}
    assert len({(m.ns, m.id) for m in rest}) == len(rest)
    cube_marker = next(m for m in rest if m.ns.endswith("/c"))
    assert cube_marker.type == Marker.CUBE and cube_marker.scale.x == pytest.approx(0.045)
    assert cube_marker.pose.position.x == pytest.approx(0.1)
    assert any(m.type == Marker.TRIANGLE_LIST and len(m.points) % 3 == 0 and m.points for m in rest)
    serialized(arr)


def test_marker_points_are_reused_within_a_scene_and_dropped_with_it():
    """A running sim node publishes markers at 2 Hz for hours: the triangle points of the current scene's parts are
    built once, and the parts of earlier scenes are not kept (the cache grew 4 MB per 100 resets before)."""
    def scene_items():
        arch = ObjectSpec(shape="arch", size=None, color=(89, 161, 79), pose=(0, 0, 0, 0, 0, 0), name="a")
        return pose_parts("a", marker_parts(arch), np.zeros(3), np.array([0, 0, 0, 1.0]), (0.35, 0.63, 0.31, 1.0))

    items = scene_items()
    triangles = sum(1 for m in items if m.part.kind == "triangles")
    assert triangles >= 1
    first = [m.points for m in conv.markers(items, 1.0, "world").markers[1:] if m.type == Marker.TRIANGLE_LIST]
    again = [m.points for m in conv.markers(items, 1.5, "world").markers[1:] if m.type == Marker.TRIANGLE_LIST]
    assert all(a is b for a, b in zip(first, again, strict=True))  # same scene: points built once
    for _ in range(50):  # 50 resets: new parts every time
        conv.markers(scene_items(), 2.0, "world")
    assert len(conv._points_cache) == triangles


def test_scene_state_and_reset_response_messages():
    pytest.importorskip("pg_msgs.msg", reason="ROS tier: pg_msgs not built or not sourced (make setup; "
                                              "source scripts/ros_env.sh)")
    state = SceneState(4.0, "packed/case01", "green", True, (
        ObjectState("t", "cube", "green", (89, 161, 79), True, (0.0, 0.0, 0.02), (0.0, 0.0, 0.0, 1.0), True),))
    msg = conv.scene_state(state, "world")
    assert msg.header.frame_id == "world" and msg.scene == "packed/case01" and msg.target_in_workspace
    o = msg.objects[0]
    assert o.name == "t" and o.target and o.color.g == pytest.approx(161 / 255) and o.pose.orientation.w == 1.0
    serialized(msg)
    ok = conv.reset_response(ResetResult(True, "loaded", "packed/case01", "green", 7))
    assert ok.success and ok.num_objects == 7
    late = conv.reset_response(None, 60.0)
    assert not late.success and "timed out" in late.message
