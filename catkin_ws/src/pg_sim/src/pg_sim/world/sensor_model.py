"""Sensor models of the simulated RGB-D camera, chosen by profile (ROS-free; numpy, scipy, OpenCV).

A profile (`SensorProfile`) is `perfect` (the rendered images as they are: no model at all), a shipped one
(`d435`, `d415`: pg_sim's config/sensors/<name>.yaml) or a user YAML file with the same keys. `make_sensor` turns a
profile into a seeded `SimSensor`, or None for a perfect one, which `pg_sim.world.camera.SimCamera` applies to every
capture. Raises ValueError for an unknown profile name (listing the known ones), an unknown key or a bad value.

What a model does, per frame, in this order (one numpy Generator drawn from in a fixed order: equal seeds and equal
captures give equal frames):
- depth (H, W) float32 m along the optical axis, 0 = no return:
  axial noise of RMS sigma_z(z) = z^2 * subpixel / (fx * baseline) (Intel's RMS error of a D4xx stereo depth, with
  fx the colour camera's focal length in px from the geometry config), split into a white part and a spatially
  correlated low-frequency part (a share `correlated_fraction` of the variance: white noise on a coarse grid every
  `correlation_px` px, bicubically upsampled and scaled to unit standard deviation);
  quantisation to `quantisation_m`;
  no return (0) within `edge_width_px` px on either side of a depth jump of more than `edge_jump_m` between
  neighbouring pixels of the rendered depth (the invalid bands of stereo depth along depth discontinuities), and at
  a random fraction `dropout` of the pixels.
- colour (H, W, 3) uint8 RGB: one exposure gain ~ N(1, exposure_sigma) and per-channel white-balance gains
  ~ N(1, white_balance_sigma) per frame, then Gaussian pixel noise of `color_noise` levels (of 255), rounded, clipped.
- pose: the camera renders from its configured pose (world <- optical) times an error transform, drawn when the
  sensor is seeded: a rotation of exactly `pose_rotation_deg` about a random axis and a translation of exactly
  `pose_translation_m` in a random direction, both in the optical frame. Everything downstream keeps assuming the
  configured pose, as a stack with an imperfect hand-eye calibration does.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields
from pathlib import Path

import cv2
import numpy as np
import yaml
from scipy.spatial.transform import Rotation

from pg_core.resources import package_path

PERFECT = "perfect"


@dataclass(frozen=True)
class SensorProfile:
    """The parameters of a sensor model; every default is "no such effect", so the default profile is perfect."""

    name: str = PERFECT
    baseline_m: float = 0.0            # stereo baseline (m); 0: no axial noise
    subpixel: float = 0.0              # RMS subpixel disparity error (px)
    correlated_fraction: float = 0.0   # share in [0, 1] of the axial variance in the low-frequency field
    correlation_px: float = 24.0       # grid step (px) of the low-frequency field
    quantisation_m: float = 0.0        # depth step (m); 0: none
    edge_jump_m: float = 0.01          # a depth jump (m) between neighbouring pixels that counts as an edge
    edge_width_px: int = 0             # invalid pixels on either side of an edge; 0: none
    dropout: float = 0.0               # fraction in [0, 1) of pixels without a return, at random
    exposure_sigma: float = 0.0        # standard deviation of the per-frame exposure gain around 1
    white_balance_sigma: float = 0.0   # standard deviation of the per-frame, per-channel gains around 1
    color_noise: float = 0.0           # standard deviation of the pixel noise (levels of 255)
    pose_translation_m: float = 0.0    # camera position error (m)
    pose_rotation_deg: float = 0.0     # camera orientation error (deg)

    def __post_init__(self) -> None:
        bad = [f.name for f in fields(self) if f.name != "name" and not (float(getattr(self, f.name)) >= 0.0)]
        if bad or self.correlated_fraction > 1.0 or self.dropout >= 1.0 or self.correlation_px < 1.0:
            raise ValueError(f"sensor profile {self.name!r}: {', '.join(bad) or 'a value'} out of range (all >= 0, "
                             "correlated_fraction <= 1, dropout < 1, correlation_px >= 1)")

    @property
    def perfect(self) -> bool:
        """True when the profile changes nothing (the images as rendered, the configured pose)."""
        return all(getattr(self, f.name) == getattr(PERFECT_PROFILE, f.name) for f in fields(self)
                   if f.name not in ("name", "correlation_px", "edge_jump_m"))

    def axial_sigma(self, z: np.ndarray | float, fx: float) -> np.ndarray | float:
        """RMS axial depth error (m) at depth z (m): z^2 * subpixel / (fx * baseline); 0 without a baseline."""
        if self.baseline_m <= 0.0:
            return np.zeros_like(z) if isinstance(z, np.ndarray) else 0.0
        return np.square(z) * self.subpixel / (fx * self.baseline_m)


PERFECT_PROFILE = SensorProfile()


def profile_folder() -> Path:
    """pg_sim's config/sensors/ folder: the shipped profiles, one <name>.yaml each."""
    return package_path("pg_sim") / "config" / "sensors"


def known_profiles() -> list[str]:
    """The profile names `load_profile` takes: perfect and the shipped YAML files."""
    folder = profile_folder()
    shipped = sorted(p.stem for p in folder.glob("*.yaml")) if folder.is_dir() else []
    return [PERFECT, *[s for s in shipped if s != PERFECT]]


def load_profile(spec: str | Path | SensorProfile) -> SensorProfile:
    """The profile of a name (perfect, d435, d415) or of a YAML file (a mapping of SensorProfile keys; `name`
    defaults to the file's stem). Raises ValueError naming the known profiles for anything else, or for a file with
    an unknown key or a bad value."""
    if isinstance(spec, SensorProfile):
        return spec
    text = str(spec)
    if text == PERFECT:
        return PERFECT_PROFILE
    path = Path(text).expanduser()
    if not (path.suffix in (".yaml", ".yml") and path.is_file()):
        shipped = profile_folder() / f"{text}.yaml"
        if "/" in text or not shipped.is_file():
            raise ValueError(f"unknown sensor profile {text!r}: known {', '.join(known_profiles())}, or a YAML file "
                             "of pg_sim.world.sensor_model.SensorProfile keys")
        path = shipped
    data = yaml.safe_load(path.read_text(encoding="utf-8")) or {}
    if not isinstance(data, dict):
        raise ValueError(f"sensor profile {path}: expected a mapping of SensorProfile keys")
    keys = {f.name for f in fields(SensorProfile)}
    unknown = sorted(set(data) - keys)
    if unknown:
        raise ValueError(f"sensor profile {path}: unknown key(s) {', '.join(unknown)} "
                         f"(known: {', '.join(sorted(keys))})")
    data.setdefault("name", path.stem)
    try:
        values = {k: (str(v) if k == "name" else int(v) if k == "edge_width_px" else float(v)) for k, v in data.items()}
    except (TypeError, ValueError) as exc:
        raise ValueError(f"sensor profile {path}: {exc}") from exc
    return SensorProfile(**values)


def depth_edges(depth: np.ndarray, jump_m: float, width_px: int) -> np.ndarray:
    """(H, W) bool: pixels within `width_px` px (Chebyshev) on either side of a jump of more than `jump_m` (m)
    between 4-neighbours of `depth` (H, W) m; a return next to no return (0) is a jump. All False for width 0."""
    d = np.asarray(depth, dtype=np.float64)
    edge = np.zeros(d.shape, dtype=bool)
    if width_px <= 0:
        return edge
    dx = np.abs(np.diff(d, axis=1)) > jump_m
    dy = np.abs(np.diff(d, axis=0)) > jump_m
    edge[:, :-1] |= dx
    edge[:, 1:] |= dx
    edge[:-1, :] |= dy
    edge[1:, :] |= dy
    if width_px > 1:
        kernel = np.ones((2 * width_px - 1, 2 * width_px - 1), dtype=np.uint8)
        edge = cv2.dilate(edge.astype(np.uint8), kernel).astype(bool)
    return edge


class SimSensor:
    """A seeded sensor model: `apply` turns rendered images into sensed ones, `render_pose` gives the pose the
    camera renders from. Not thread-safe (one Generator)."""

    def __init__(self, profile: SensorProfile, seed: int = 0) -> None:
        self.profile = profile
        self.seed(seed)

    def seed(self, seed: int) -> None:
        """Restart the random stream from `seed` and draw the pose error of this seed."""
        self.rng = np.random.default_rng(seed)
        self.pose_error = self._draw_pose_error()

    def _draw_pose_error(self) -> np.ndarray:
        """4x4 optical <- rendered-optical transform of the profile's magnitudes in random directions."""
        p = self.profile
        axis, direction = self.rng.standard_normal(3), self.rng.standard_normal(3)
        err = np.eye(4)
        err[:3, :3] = Rotation.from_rotvec(math.radians(p.pose_rotation_deg) * axis / np.linalg.norm(axis)).as_matrix()
        err[:3, 3] = p.pose_translation_m * direction / np.linalg.norm(direction)
        return err

    def render_pose(self, pose: np.ndarray) -> np.ndarray:
        """The 4x4 pose (world <- optical) the camera renders from when it is configured at `pose`."""
        return np.asarray(pose, dtype=np.float64) @ self.pose_error

    def apply(self, color: np.ndarray, depth: np.ndarray, fx: float) -> tuple[np.ndarray, np.ndarray]:
        """Sensed (colour (H, W, 3) uint8, depth (H, W) float32 m, 0 = no return) of rendered ones; fx: px."""
        return self._color(color), self._depth(depth, fx)

    def _depth(self, depth: np.ndarray, fx: float) -> np.ndarray:
        p, rng = self.profile, self.rng
        z = np.asarray(depth, dtype=np.float64)
        shape = z.shape
        white = rng.standard_normal(shape)
        field = self._low_frequency(shape)
        drop = rng.random(shape) < p.dropout
        c = p.correlated_fraction
        noisy = z + np.asarray(p.axial_sigma(z, fx)) * (math.sqrt(1.0 - c) * white + math.sqrt(c) * field)
        if p.quantisation_m > 0.0:
            noisy = np.round(noisy / p.quantisation_m) * p.quantisation_m
        invalid = (z <= 0.0) | ~(noisy > 0.0) | drop | depth_edges(z, p.edge_jump_m, p.edge_width_px)
        return np.where(invalid, 0.0, noisy).astype(np.float32)

    def _low_frequency(self, shape: tuple[int, ...]) -> np.ndarray:
        """(H, W) float64 smooth noise of unit standard deviation, correlated over about `correlation_px` px."""
        h, w = shape
        step = self.profile.correlation_px
        coarse = self.rng.standard_normal((int(math.ceil(h / step)) + 3, int(math.ceil(w / step)) + 3))
        big = cv2.resize(coarse, (int(round(coarse.shape[1] * step)), int(round(coarse.shape[0] * step))),
                         interpolation=cv2.INTER_CUBIC)
        off = int(round(step))  # skip the first coarse cell: the upsampling's border
        field = big[off:off + h, off:off + w]
        return field / max(float(field.std()), 1e-12)

    def _color(self, color: np.ndarray) -> np.ndarray:
        p, rng = self.profile, self.rng
        gain = 1.0 + p.exposure_sigma * rng.standard_normal()
        balance = 1.0 + p.white_balance_sigma * rng.standard_normal(3)
        out = rng.standard_normal(np.shape(color), dtype=np.float32)  # float32 throughout: 3 x 2 MB per frame
        out *= np.float32(p.color_noise)
        out += np.asarray(color, dtype=np.float32) * (gain * balance).astype(np.float32)
        return np.clip(np.rint(out, out=out), 0, 255, out=out).astype(np.uint8)


def make_sensor(spec: str | Path | SensorProfile | SimSensor | None, seed: int = 0) -> SimSensor | None:
    """A seeded sensor for a profile name, YAML path or profile; None for a perfect profile (and for None). A
    SimSensor is returned as it is. Raises ValueError as `load_profile`."""
    if spec is None or isinstance(spec, SimSensor):
        return spec
    profile = load_profile(spec)
    return None if profile.perfect else SimSensor(profile, seed)

