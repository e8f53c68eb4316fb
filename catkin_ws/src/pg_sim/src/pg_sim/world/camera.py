"""Simulated RealSense-like RGB-D camera: PyBullet rendering with the intrinsics of the geometry config.

Images follow the RealSense driver: colour (H, W, 3) uint8 RGB, depth (H, W) float32 metres along the optical axis
(0 where nothing was hit), both in `camera_color_optical_frame` (x right, y down, z forward).
A sensor model (pg_sim.world.sensor_model; none: the perfect camera) turns each rendering into what a real sensor
would see, and may make the camera render from a pose other than the configured `pose` that everything else assumes.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pybullet as p

from pg_core.geometry import CameraSpec
from pg_sim.world.sensor_model import SimSensor

# optical frame (x right, y down, z forward) -> OpenGL camera frame (x right, y up, z backward)
_OPTICAL_TO_GL = np.diag([1.0, -1.0, -1.0, 1.0])


@dataclass(frozen=True)
class Frame:
    """One capture: color (H, W, 3) uint8; depth (H, W) float32 m (0 = no return); segmentation (H, W) int32 ids."""

    color: np.ndarray
    depth: np.ndarray
    segmentation: np.ndarray


def view_matrix(pose_world_optical: np.ndarray) -> list[float]:
    """PyBullet (column-major) view matrix for a camera whose optical frame has the given 4x4 pose in world."""
    world_to_gl = np.linalg.inv(pose_world_optical @ _OPTICAL_TO_GL)
    return world_to_gl.T.reshape(-1).tolist()


def projection_matrix(spec: CameraSpec) -> list[float]:
    """PyBullet (column-major) projection matrix reproducing fx, fy, cx, cy (pixel-centre convention)."""
    w, h, n, f = spec.width, spec.height, spec.near, spec.far
    proj = np.array(
        [
            [2.0 * spec.fx / w, 0.0, 1.0 - (2.0 * spec.cx + 1.0) / w, 0.0],
            [0.0, 2.0 * spec.fy / h, (2.0 * spec.cy + 1.0) / h - 1.0, 0.0],
            [0.0, 0.0, -(f + n) / (f - n), -2.0 * f * n / (f - n)],
            [0.0, 0.0, -1.0, 0.0],
        ]
    )
    return proj.T.reshape(-1).tolist()


def depth_to_points(depth: np.ndarray, k: np.ndarray) -> np.ndarray:
    """Back-project a metric depth image to (H*W, 3) points in the optical frame; invalid pixels become NaN."""
    h, w = depth.shape
    v, u = np.mgrid[0:h, 0:w]
    z = depth.astype(np.float64)
    x = (u - k[0, 2]) * z / k[0, 0]
    y = (v - k[1, 2]) * z / k[1, 1]
    pts = np.stack([x, y, z], axis=-1).reshape(-1, 3)
    pts[z.reshape(-1) <= 0] = np.nan
    return pts


def project_points(points_cam: np.ndarray, k: np.ndarray) -> np.ndarray:
    """Pinhole projection of (N, 3) optical-frame points to (N, 2) pixel coordinates (u, v)."""
    pts = np.asarray(points_cam, dtype=np.float64).reshape(-1, 3)
    uv = pts[:, :2] / pts[:, 2:3]
    return uv * np.array([k[0, 0], k[1, 1]]) + np.array([k[0, 2], k[1, 2]])


class SimCamera:
    """Renders the PyBullet scene. `pose` (4x4 world <- optical) is the configured pose, the one the heightmap
    assumes; `render_pose` is the one it renders from: `pose` itself, or `pose` times the sensor's pose error."""

    def __init__(self, client: int, spec: CameraSpec, renderer: int = p.ER_TINY_RENDERER,
                 sensor: SimSensor | None = None) -> None:
        self.client_ = client
        self.spec = spec
        self.pose = spec.pose
        self.intrinsics = spec.intrinsics
        self.proj_ = projection_matrix(spec)
        self.renderer_ = renderer
        self.use_sensor(sensor)

    def use_sensor(self, sensor: SimSensor | None) -> None:
        """Apply `sensor` to every capture and render from its pose (None: the perfect camera at `pose`)."""
        self.sensor = sensor
        self.render_pose = self.pose if sensor is None else sensor.render_pose(self.pose)
        self.view_ = view_matrix(self.render_pose)

    def seed_sensor(self, seed: int) -> None:
        """Restart the sensor's random stream (and its pose error) from `seed`; nothing for the perfect camera."""
        if self.sensor is not None:
            self.sensor.seed(seed)
            self.use_sensor(self.sensor)

    def capture(self) -> Frame:
        """One frame as sensed: the rendering through the sensor model (as rendered without one)."""
        frame = self.render()
        if self.sensor is None:
            return frame
        color, depth = self.sensor.apply(frame.color, frame.depth, float(self.spec.fx))
        return Frame(color=color, depth=depth, segmentation=frame.segmentation)

    def render(self) -> Frame:
        """One frame as rendered from `render_pose`: exact depth, no sensor model."""
        s = self.spec
        _, _, rgba, zbuf, seg = p.getCameraImage(
            s.width,
            s.height,
            viewMatrix=self.view_,
            projectionMatrix=self.proj_,
            renderer=self.renderer_,
            shadow=0,
            lightDirection=[0.3, 0.2, 1.0],
            lightAmbientCoeff=0.65,  # soft light: vertical faces stay close to their colour, as under room light
            lightDiffuseCoeff=0.4,
            lightSpecularCoeff=0.02,
            physicsClientId=self.client_,
        )
        rgba = np.asarray(rgba, dtype=np.uint8).reshape(s.height, s.width, 4)
        zbuf = np.asarray(zbuf, dtype=np.float64).reshape(s.height, s.width)
        depth = s.far * s.near / (s.far - (s.far - s.near) * zbuf)
        depth[zbuf >= 1.0 - 1e-7] = 0.0
        seg = np.asarray(seg, dtype=np.int32).reshape(s.height, s.width)
        return Frame(color=rgba[:, :, :3].copy(), depth=depth.astype(np.float32), segmentation=seg)

    def point_cloud(self, frame: Frame) -> tuple[np.ndarray, np.ndarray]:
        """(N, 3) float64 optical-frame points (NaN where no return) and their (N, 3) uint8 colours."""
        return depth_to_points(frame.depth, self.intrinsics), frame.color.reshape(-1, 3)
