"""Values exchanged with `pg_sim.runtime.sim_runtime.SimRuntime` (no ROS): reset requests and results, joint states,
camera captures, ground-truth scene state and the per-step output. Units: seconds of sim time, metres, radians."""

from __future__ import annotations

import threading
from dataclasses import dataclass, field

import numpy as np

from pg_sim.scenes.scene_limits import DEFAULT_LIMITS, SceneLimits
from pg_sim.world.rest import REST_TIMEOUT
from pg_sim.world.sensor_data import ObjectMarker


@dataclass(frozen=True)
class ResetRequest:
    """A scene name ("packed/case01"), a YAML path, "random" (num_objects from seed) or "random-N"."""

    scene: str
    num_objects: int = 0
    seed: int = 0


@dataclass(frozen=True)
class ResetResult:
    """The answer to a reset; ``resets`` counts the successful resets since start-up, this one included (0: the
    initial scene)."""

    success: bool
    message: str
    scene_name: str = ""
    target: str = ""
    num_objects: int = 0
    resets: int = 0


class PendingReset:
    """A reset queued from another thread; `wait()` returns its result, or None on timeout."""

    def __init__(self, request: ResetRequest) -> None:
        self.request = request
        self.result: ResetResult | None = None
        self.done_ = threading.Event()

    def finish(self, result: ResetResult) -> None:
        self.result = result
        self.done_.set()

    def wait(self, timeout: float | None = None) -> ResetResult | None:
        return self.result if self.done_.wait(timeout) else None


@dataclass(frozen=True)
class JointStateData:
    stamp: float
    names: tuple[str, ...]
    positions: np.ndarray
    velocities: np.ndarray


@dataclass(frozen=True)
class CameraCapture:
    """One capture: colour (H, W, 3) uint8 RGB, depth (H, W) float32 m (NaN = no return), organised cloud (H, W)
    sensor_data.CLOUD_DTYPE in the optical frame; ``seq`` changes only when the scene was rendered anew."""

    stamp: float
    color: np.ndarray
    depth: np.ndarray
    cloud: np.ndarray
    seq: int
    rendered: bool
    render_s: float  # wall seconds spent rendering + building (0 when re-used)


@dataclass(frozen=True)
class ObjectState:
    name: str
    shape: str
    color_name: str
    rgb: tuple[int, int, int]
    target: bool
    position: tuple[float, float, float]
    quaternion: tuple[float, float, float, float]  # x, y, z, w
    in_workspace: bool


@dataclass(frozen=True)
class SceneState:
    stamp: float
    scene: str
    target: str
    target_in_workspace: bool
    objects: tuple[ObjectState, ...]


@dataclass
class StepOutput:
    """What one step made due (None / False when not due) and warnings about refused commands."""

    sim_time: float
    busy: bool
    clock: bool = False
    joint_state: JointStateData | None = None
    camera: CameraCapture | None = None
    scene_state: SceneState | None = None
    markers: list[ObjectMarker] | None = None
    messages: list[str] = field(default_factory=list)


@dataclass(frozen=True)
class RuntimeConfig:
    """Rates are in Hz of sim time (<= 0 disables the output); real-time factors: 0 = as fast as possible.
    ``limits`` bound every scene file, ``scene_folders`` are added to the folders that reset requests may name files
    in (pg_sim.scenes.scene_folders), ``rest_timeout`` is the sim time (s) a reset gives moving objects to stop."""

    scene: str = "packed/case01"
    seed: int = 0
    num_objects: int = 10
    gui: bool = False
    time_step: float = 1.0 / 240.0
    camera_rate: float = 2.0
    joint_state_rate: float = 50.0
    clock_rate: float = 100.0
    scene_state_rate: float = 2.0
    real_time_factor: float = 0.0       # cap while something moves
    idle_real_time_factor: float = 1.0  # cap while nothing moves
    limits: SceneLimits = DEFAULT_LIMITS
    scene_folders: tuple[str, ...] = ()
    rest_timeout: float = REST_TIMEOUT
    calibration_board: str = ""  # an arm name: the ChArUco board is mounted on its tool (World.attach_board)
