#!/usr/bin/env python3
"""rostest node of heightmap_projector.test: the C++ heightmap_projector_node against the numpy reference.

A PyBullet scene (pg_sim World + packed/case01) is rendered once by the simulated camera. Its cloud is published as an
organised PointCloud2 XYZRGB (float32 x, y, z and packed rgb, NaN where no return) in camera_color_optical_frame, and
its images (rgb8 colour, 32FC1 aligned depth, camera_info) as the RealSense driver names them. The heightmaps that
come back on /pg/heightmap (cloud input) and /pg/heightmap_depth (depth input) are compared with
pg_core.heightmap.from_camera_cloud on the same points: >= 99.9 % of cells equal within 1 mm in height, equal
validity masks, equal colours on valid cells. The world <- camera transform is broadcast here, statically, from the
camera pose of config/workspace.yaml.
"""

from __future__ import annotations

import time
import unittest

import numpy as np
import rospy
import rostest
import tf2_ros
from geometry_msgs.msg import TransformStamped
from pg_msgs.msg import Heightmap as HeightmapMsg
from scipy.spatial.transform import Rotation
from sensor_msgs.msg import CameraInfo, Image, PointCloud2, PointField
from std_msgs.msg import Header

from pg_core import heightmap as hm
from pg_core.geometry import load

PKG = "pg_tests"
SCENE = "packed/case01"
TIMEOUT_S = 60.0  # wall seconds for a heightmap to come back
MIN_AGREEMENT = 0.999  # fraction of cells whose heights agree within HEIGHT_TOL_M
HEIGHT_TOL_M = 1e-3


def cloud_msg(points: np.ndarray, colors: np.ndarray, width: int, height: int, header: Header) -> PointCloud2:
    """Organised XYZRGB PointCloud2 (point_step 16: float32 x, y, z, rgb packed 0x00RRGGBB as PCL does)."""
    arr = np.empty(len(points), dtype=[("x", "<f4"), ("y", "<f4"), ("z", "<f4"), ("rgb", "<u4")])
    for i, name in enumerate("xyz"):
        arr[name] = points[:, i]
    c = colors.astype(np.uint32)
    arr["rgb"] = (c[:, 0] << 16) | (c[:, 1] << 8) | c[:, 2]
    fields = [PointField(name, 4 * i, PointField.FLOAT32, 1) for i, name in enumerate(("x", "y", "z", "rgb"))]
    return PointCloud2(header=header, height=height, width=width, fields=fields, is_bigendian=False, point_step=16,
                       row_step=16 * width, data=arr.tobytes(), is_dense=False)


def image_msg(img: np.ndarray, encoding: str, header: Header) -> Image:
    img = np.ascontiguousarray(img)
    h, w = img.shape[:2]
    return Image(header=header, height=h, width=w, encoding=encoding, is_bigendian=0, step=img.strides[0],
                 data=img.tobytes())


def grid_of(msg: HeightmapMsg) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(colour (H, W, 3) uint8, height (H, W) float32, valid (H, W) bool) of a pg_msgs/Heightmap."""
    h, w = msg.height.height, msg.height.width
    color = np.frombuffer(msg.color.data, dtype=np.uint8).reshape(h, w, 3)
    height = np.frombuffer(msg.height.data, dtype="<f4").reshape(h, w)
    valid = np.frombuffer(msg.valid.data, dtype=np.uint8).reshape(h, w)
    return color, height, valid == 255


class HeightmapProjectorVsNumpy(unittest.TestCase):
    @classmethod
    def setUpClass(cls) -> None:
        rospy.init_node("rt_heightmap_projector")
        from pg_sim.scenes.scene import load_scene
        from pg_sim.world.world import World

        cls.geometry = g = load()
        with World(g) as world:
            world.load_scene(load_scene(SCENE))
            cls.frame = world.capture()
            cls.points, cls.colors = world.camera.point_cloud(cls.frame)
        cam = g.camera
        t = TransformStamped()
        t.header.stamp = rospy.Time.now()
        t.header.frame_id, t.child_frame_id = g.world_frame, g.camera_frame
        t.transform.translation.x, t.transform.translation.y, t.transform.translation.z = cam.xyz
        q = Rotation.from_euler("xyz", cam.rpy).as_quat()  # x, y, z, w
        r = t.transform.rotation
        r.x, r.y, r.z, r.w = (float(v) for v in q)
        cls.broadcaster = tf2_ros.StaticTransformBroadcaster()
        cls.broadcaster.sendTransform(t)

    def publish_until_answer(self, topic: str, publish) -> HeightmapMsg:
        """Call publish(header) with fresh stamps until `topic` answers one of them; returns that heightmap."""
        got: list[HeightmapMsg] = []
        sub = rospy.Subscriber(topic, HeightmapMsg, got.append, queue_size=5)
        sent: set[tuple[int, int]] = set()
        deadline = time.monotonic() + TIMEOUT_S
        try:
            i = 0
            while time.monotonic() < deadline and not rospy.is_shutdown():
                match = [m for m in got if (m.header.stamp.secs, m.header.stamp.nsecs) in sent]
                if match:
                    return match[0]
                # Odd stamps (nanoseconds set) check that the node keeps the source stamp exactly.
                header = Header(stamp=rospy.Time(1000 + i, 123456789), frame_id=self.geometry.camera_frame)
                sent.add((header.stamp.secs, header.stamp.nsecs))
                publish(header)
                i += 1
                time.sleep(0.5)
        finally:
            sub.unregister()
        self.fail(f"no heightmap on {topic} for the published data within {TIMEOUT_S} s")

    def compare(self, msg: HeightmapMsg, ref: hm.Heightmap, label: str) -> None:
        g = self.geometry
        self.assertEqual(msg.header.frame_id, g.world_frame)
        self.assertAlmostEqual(msg.resolution, g.heightmap.resolution, places=12)
        np.testing.assert_allclose([msg.x_min, msg.x_max, msg.y_min, msg.y_max, msg.z_min, msg.z_max],
                                   g.workspace.bounds.reshape(-1), atol=1e-12)
        self.assertEqual((msg.color.encoding, msg.height.encoding, msg.valid.encoding), ("rgb8", "32FC1", "mono8"))
        color, height, valid = grid_of(msg)
        self.assertEqual(height.shape, (g.heightmap.rows, g.heightmap.cols))
        self.assertGreater(ref.valid.mean(), 0.9, "the reference sees too little of the workspace")
        self.assertGreater(float(ref.height.max()), 0.02, "no objects in the reference heightmap")

        agree = float(np.mean(np.abs(height - ref.height) <= HEIGHT_TOL_M))
        valid_diff = int(np.sum(valid != ref.valid))
        both = valid & ref.valid
        color_eq = np.all(color == ref.color, axis=-1)
        color_diff = int(np.sum(~color_eq[both]))
        max_dh = float(np.max(np.abs(height - ref.height)))
        print(f"[{label}] {height.size} cells: heights within 1 mm {100 * agree:.4f} % (max |dh| {max_dh:.2e} m), "
              f"valid differs in {valid_diff}, colour differs in {color_diff} of {int(both.sum())} valid cells",
              flush=True)
        self.assertGreaterEqual(agree, MIN_AGREEMENT, label)
        self.assertEqual(valid_diff, 0, label)
        self.assertEqual(color_diff, 0, label)
        self.assertTrue(np.all(height >= 0.0) and np.all(height[~valid] == 0.0) and np.all(color[~valid] == 0))

    def test_cloud_input(self) -> None:
        cam = self.geometry.camera
        pts32 = self.points.astype(np.float32)
        pub = rospy.Publisher("/camera/depth/color/points", PointCloud2, queue_size=1)
        msg = self.publish_until_answer(
            "/pg/heightmap", lambda h: pub.publish(cloud_msg(pts32, self.colors, cam.width, cam.height, h)))
        # The reference on exactly the points that were sent (float32 on the wire).
        ref = hm.from_camera_cloud(pts32.astype(np.float64), self.colors, cam.pose, self.geometry)
        self.compare(msg, ref, "cloud")

    def test_depth_input(self) -> None:
        cam = self.geometry.camera
        pubs = {
            "color": rospy.Publisher("/camera/color/image_raw", Image, queue_size=1),
            "depth": rospy.Publisher("/camera/aligned_depth_to_color/image_raw", Image, queue_size=1),
            "info": rospy.Publisher("/camera/color/camera_info", CameraInfo, queue_size=1),
        }
        k = cam.intrinsics

        def publish(header: Header) -> None:
            info = CameraInfo(header=header, width=cam.width, height=cam.height, distortion_model="plumb_bob",
                              D=[0.0] * 5, K=k.reshape(-1).tolist(), R=np.eye(3).reshape(-1).tolist(),
                              P=np.hstack([k, np.zeros((3, 1))]).reshape(-1).tolist())
            pubs["color"].publish(image_msg(self.frame.color, "rgb8", header))
            pubs["depth"].publish(image_msg(self.frame.depth.astype(np.float32), "32FC1", header))
            pubs["info"].publish(info)

        msg = self.publish_until_answer("/pg/heightmap_depth", publish)
        ref = hm.from_camera_cloud(self.points, self.colors, cam.pose, self.geometry)  # depth_to_points, float64
        self.compare(msg, ref, "depth")


if __name__ == "__main__":
    rostest.rosrun(PKG, "rt_heightmap_projector", HeightmapProjectorVsNumpy)
