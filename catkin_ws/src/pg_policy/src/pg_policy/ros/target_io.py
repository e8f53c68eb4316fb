"""A request's target (pg_msgs GraspTarget / Infer `target`, `point`, `mask`) as a target spec, over ROS: points go
through tf2 to `world`, masks through the colour camera's camera_info and tf2 onto the heightmap grid. The checks
themselves are pg_policy.ros.target_request's (ROS-free); every refusal is a ValueError led by the request field.

Waits: each tf2 lookup at most `tf_timeout_s` wall seconds; a mask's heightmap at most `heightmap_timeout_s`.
"""

from __future__ import annotations

import threading

import numpy as np
import rospy
import tf2_ros
from geometry_msgs.msg import PointStamped
from sensor_msgs.msg import CameraInfo, Image

from pg_core.user_text import cut
from pg_policy.perception.mask_projection import project_mask, quaternion_matrix
from pg_policy.ros import target_request as tr
from pg_policy.ros.loop_io import TopicHeightmapSource
from pg_policy.target_loop.target_spec import TargetSpec

WORLD = "world"


class TargetRequests:
    """Turns the target fields of a request into what TargetLoop takes (a colour name or a TargetSpec)."""

    def __init__(self, source: TopicHeightmapSource, workspace: np.ndarray, camera_info_topic: str,
                 tf_timeout_s: float, mask_max_skew_s: float, heightmap_timeout_s: float) -> None:
        self.source, self.workspace = source, np.asarray(workspace, dtype=np.float64)
        self.tf_timeout_s, self.mask_max_skew_s = tf_timeout_s, mask_max_skew_s
        self.heightmap_timeout_s = heightmap_timeout_s
        self.tf_ = tf2_ros.Buffer(cache_time=rospy.Duration(30.0))
        self.listener_ = tf2_ros.TransformListener(self.tf_)
        self.lock_ = threading.Lock()
        self.info_: CameraInfo | None = None  # latest colour camera_info
        self.sub_info_ = rospy.Subscriber(camera_info_topic, CameraInfo, self._on_info, queue_size=1)

    def _on_info(self, msg: CameraInfo) -> None:
        with self.lock_:
            self.info_ = msg

    def target(self, req) -> tuple[str, str | TargetSpec]:
        """(form, target) of a request with fields target, point and mask; ValueError led by the field at fault."""
        form = tr.request_form(req.target, req.point.header.frame_id, len(req.mask.data))
        if form == "point":
            return form, self.point(req.point)
        if form == "mask":
            return form, self.mask(req.mask)
        return form, req.target

    def point(self, msg: PointStamped) -> TargetSpec:
        """The PointTarget of a stamped point in any frame tf2 reaches (stamp 0: the latest transform)."""
        pose = self._transform(WORLD, msg.header.frame_id, msg.header.stamp, "point")
        p = pose @ np.array([msg.point.x, msg.point.y, msg.point.z, 1.0])
        return tr.point_target((p[0], p[1], p[2]), self.workspace)

    def mask(self, msg: Image) -> TargetSpec:
        """The MaskTarget of a mono8 camera mask, projected with the heightmap nearest its stamp."""
        with self.lock_:
            info = self.info_
        size = (int(info.width), int(info.height)) if info is not None else None
        image = tr.mask_image(msg.encoding, msg.width, msg.height, msg.step, msg.data, size)
        assert info is not None  # mask_image refuses an unknown camera size
        frame = msg.header.frame_id or info.header.frame_id
        if frame != info.header.frame_id:
            raise ValueError(f"mask: frame '{cut(frame)}' is not the colour camera's '{cut(info.header.frame_id)}'")
        stamp = msg.header.stamp.to_sec()
        tr.check_skew(stamp, stamp, self.mask_max_skew_s)  # a zero stamp
        shm = self.source.wait_after(stamp - self.mask_max_skew_s, self.heightmap_timeout_s)
        tr.check_skew(stamp, shm.stamp, self.mask_max_skew_s)
        camera_from_world = self._transform(frame, WORLD, msg.header.stamp, "mask")
        grid = project_mask(image, shm.heightmap, np.asarray(info.K, dtype=np.float64).reshape(3, 3),
                            camera_from_world)
        return tr.mask_target(grid)

    def _transform(self, target: str, source: str, stamp: rospy.Time, field: str) -> np.ndarray:
        """4x4 transform target <- source at `stamp`; ValueError led by `field` when tf2 has none in time."""
        try:
            t = self.tf_.lookup_transform(target, source, stamp, rospy.Duration(self.tf_timeout_s))
        except tf2_ros.TransformException as exc:
            raise ValueError(f"{field}: no transform from frame '{cut(source)}' to '{cut(target)}' within "
                             f"{self.tf_timeout_s:g} s ({cut(str(exc), 100)})") from None
        tl, q = t.transform.translation, t.transform.rotation
        return quaternion_matrix((tl.x, tl.y, tl.z), (q.x, q.y, q.z, q.w))
