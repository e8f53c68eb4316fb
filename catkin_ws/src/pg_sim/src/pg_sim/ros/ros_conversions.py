"""Conversions between the sim runtime's plain data and ROS messages (message classes only: no rospy, no node).

Used by nodes/sim_node. Stamps are sim time (seconds) turned into ROS time; frames are passed in by the caller.
"""

from __future__ import annotations

import numpy as np
from genpy import Time
from geometry_msgs.msg import Point, Pose
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import CameraInfo, Image, JointState, PointCloud2, PointField
from std_msgs.msg import ColorRGBA, Header
from visualization_msgs.msg import Marker, MarkerArray

from pg_conversions.heightmap_msg import image_msg
from pg_core.geometry import CameraSpec
from pg_sim.robot.trajectory import JointTrajectory, TrajectoryPoint
from pg_sim.runtime.runtime_types import CameraCapture, JointStateData, ResetRequest, ResetResult, SceneState
from pg_sim.world.sensor_data import CLOUD_FIELDS, MarkerPart, ObjectMarker


def stamp(t: float) -> Time:
    return Time.from_sec(max(float(t), 0.0))


def clock(t: float) -> Clock:
    return Clock(clock=stamp(t))


def header(t: float, frame: str) -> Header:
    return Header(stamp=stamp(t), frame_id=frame)


def joint_state(js: JointStateData) -> JointState:
    return JointState(header=header(js.stamp, ""), name=list(js.names), position=js.positions.tolist(),
                      velocity=js.velocities.tolist(), effort=[])


def trajectory(msg) -> JointTrajectory:  # trajectory_msgs/JointTrajectory
    points = tuple(
        TrajectoryPoint(tuple(pt.positions), pt.time_from_start.to_sec(), tuple(pt.velocities)) for pt in msg.points
    )
    return JointTrajectory(tuple(msg.joint_names), points, msg.header.stamp.to_sec())


def image(array: np.ndarray, encoding: str, t: float, frame: str) -> Image:
    return image_msg(array, encoding, header(t, frame))


def camera_info(spec: CameraSpec, t: float, frame: str) -> CameraInfo:
    return CameraInfo(
        header=header(t, frame), width=spec.width, height=spec.height, distortion_model="plumb_bob",
        D=[0.0] * 5, K=[spec.fx, 0.0, spec.cx, 0.0, spec.fy, spec.cy, 0.0, 0.0, 1.0],
        R=[1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0],
        P=[spec.fx, 0.0, spec.cx, 0.0, 0.0, spec.fy, spec.cy, 0.0, 0.0, 0.0, 1.0, 0.0],
    )


def point_cloud(cloud: np.ndarray, t: float, frame: str) -> PointCloud2:
    """Organised (H, W) sensor_data.CLOUD_DTYPE array -> PointCloud2 (x, y, z, rgb FLOAT32; NaN = no return)."""
    h, w = cloud.shape
    fields = [PointField(name=n, offset=o, datatype=PointField.FLOAT32, count=1) for n, o in CLOUD_FIELDS]
    return PointCloud2(header=header(t, frame), height=h, width=w, fields=fields, is_bigendian=False,
                       point_step=cloud.dtype.itemsize, row_step=cloud.dtype.itemsize * w,
                       data=np.ascontiguousarray(cloud).tobytes(), is_dense=False)


def camera_messages(cap: CameraCapture, spec: CameraSpec, frame: str) -> dict[str, object]:
    """The five RealSense-named messages of one capture, keyed by topic suffix, all with the capture's stamp."""
    info = camera_info(spec, cap.stamp, frame)
    return {
        "color/image_raw": image(cap.color, "rgb8", cap.stamp, frame),
        "color/camera_info": info,
        "aligned_depth_to_color/image_raw": image(cap.depth, "32FC1", cap.stamp, frame),
        "aligned_depth_to_color/camera_info": camera_info(spec, cap.stamp, frame),
        "depth/color/points": point_cloud(cap.cloud, cap.stamp, frame),
    }


def restamp(msgs: dict[str, object], t: float) -> None:
    for m in msgs.values():
        m.header.stamp = stamp(t)  # type: ignore[attr-defined]


def _pose(position, quaternion) -> Pose:
    pose = Pose()
    pose.position.x, pose.position.y, pose.position.z = (float(v) for v in position)
    q = pose.orientation
    q.x, q.y, q.z, q.w = (float(v) for v in quaternion)
    return pose


def scene_state(state: SceneState, frame: str):  # -> pg_msgs/SceneState
    from pg_msgs.msg import SceneObject
    from pg_msgs.msg import SceneState as SceneStateMsg

    objects = [
        SceneObject(name=o.name, shape=o.shape, color_name=o.color_name,
                    color=ColorRGBA(o.rgb[0] / 255.0, o.rgb[1] / 255.0, o.rgb[2] / 255.0, 1.0), target=o.target,
                    pose=_pose(o.position, o.quaternion), in_workspace=o.in_workspace)
        for o in state.objects
    ]
    return SceneStateMsg(header=header(state.stamp, frame), scene=state.scene, target=state.target,
                         target_in_workspace=state.target_in_workspace, objects=objects)


_TYPES = {"cube": Marker.CUBE, "cylinder": Marker.CYLINDER, "triangles": Marker.TRIANGLE_LIST,
          "mesh": Marker.MESH_RESOURCE}
_points_cache: dict[int, tuple[MarkerPart, list[Point]]] = {}  # the parts of the last markers() call only


def _points(part: MarkerPart, cache: dict[int, tuple[MarkerPart, list[Point]]]) -> list[Point]:
    """The part's triangle points as geometry_msgs/Point, from the previous call's cache when the part is the same
    object; every hit or new entry goes into ``cache`` (the next call's cache)."""
    hit = _points_cache.get(id(part))
    if hit is None or hit[0] is not part:
        hit = (part, [] if part.points is None else [Point(*(float(c) for c in v)) for v in part.points])
    cache[id(part)] = hit
    return hit[1]


def markers(items: list[ObjectMarker], t: float, frame: str, ns: str = "pg_sim_objects") -> MarkerArray:
    """A DELETEALL then one marker per object part (namespace ``ns/<object name>``, ids = part index)."""
    global _points_cache
    out = [Marker(header=header(t, frame), action=Marker.DELETEALL)]
    cache: dict[int, tuple[MarkerPart, list[Point]]] = {}
    counts: dict[str, int] = {}
    for m in items:
        k = counts.get(m.object_name, 0)
        counts[m.object_name] = k + 1
        mk = Marker(header=header(t, frame), ns=f"{ns}/{m.object_name}", id=k, type=_TYPES[m.part.kind],
                    action=Marker.ADD, pose=_pose(m.position, m.quaternion), color=ColorRGBA(*m.rgba),
                    frame_locked=False)
        mk.scale.x, mk.scale.y, mk.scale.z = m.part.scale
        if m.part.kind == "triangles":
            mk.points = _points(m.part, cache)
        elif m.part.kind == "mesh" and m.part.mesh:
            mk.mesh_resource = "file://" + m.part.mesh
        out.append(mk)
    _points_cache = cache  # parts of earlier scenes are dropped: a long-running node's memory stays flat
    return MarkerArray(markers=out)


def reset_request(req) -> ResetRequest:  # pg_msgs/ResetSceneRequest
    return ResetRequest(scene=req.scene, num_objects=int(req.num_objects), seed=int(req.seed))


def reset_response(result: ResetResult | None, timeout: float = 0.0):  # -> pg_msgs/ResetSceneResponse
    from pg_msgs.srv import ResetSceneResponse

    if result is None:
        return ResetSceneResponse(success=False, message=f"reset timed out after {timeout:.0f} s (sim busy or stuck)")
    return ResetSceneResponse(success=result.success, message=result.message, scene_name=result.scene_name,
                              target=result.target, num_objects=result.num_objects)
