"""Publishes the camera extrinsics of a calibration YAML as a static transform (robot.launch).

Private parameter: ~file (default: pg_description/config/camera_calibration.yaml). A missing or malformed file ends the
node at start-up with the reason.
"""

from __future__ import annotations

import sys

import rospy
import tf2_ros
from geometry_msgs.msg import TransformStamped

from pg_core.resources import camera_calibration
from pg_policy.perception.calibration import CalibrationError, load_extrinsics


def main() -> None:
    rospy.init_node("camera_calibration")
    path = rospy.get_param("~file") if rospy.has_param("~file") else str(camera_calibration())
    try:
        ext = load_extrinsics(path)
    except CalibrationError as exc:
        rospy.logfatal("camera calibration: %s", exc)
        sys.exit(1)
    t = TransformStamped()
    t.header.stamp, t.header.frame_id, t.child_frame_id = rospy.Time.now(), ext.parent, ext.child
    t.transform.translation.x, t.transform.translation.y, t.transform.translation.z = ext.xyz
    q = t.transform.rotation
    q.x, q.y, q.z, q.w = ext.quaternion
    broadcaster = tf2_ros.StaticTransformBroadcaster()
    broadcaster.sendTransform(t)
    rospy.loginfo("camera calibration %s: %s -> %s", path, ext.parent, ext.child)
    rospy.spin()
