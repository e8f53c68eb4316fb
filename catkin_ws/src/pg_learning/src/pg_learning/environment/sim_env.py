"""The simulated environment the policy trains and is evaluated in: pg_sim's World seen through heightmaps.

Everything in `world`; heightmaps follow pg_core.heightmap. Decisions are executed by the real simulated arms
(pg_sim.world.primitives); a refused decision (outside the workspace, unreachable) moves nothing and is reported.
Here the policies meet the simulator: pg_policy never imports pg_sim, pg_learning does (the bottom layer of
pg_learning, under training and evaluation: docs/ARCHITECTURE.md).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from pg_core.geometry import Geometry, load
from pg_core.heightmap import Heightmap
from pg_sim.scenes.colors import nearest_color_name
from pg_sim.scenes.scene import SceneSpec, find_scene, load_scene
from pg_sim.world.primitives import PrimitiveExecutor, PrimitiveRefused
from pg_sim.world.recolour import UNIQUE, check_mode, recolour
from pg_sim.world.scene_families import generate_scene, parse_generated
from pg_sim.world.sensor_model import PERFECT
from pg_sim.world.sim_mode import DEFAULT_SIM_MODE
from pg_sim.world.world import World


@dataclass(frozen=True)
class EnvObservation:
    """heightmap: what the camera sees; target: colour name of the goal; truth_target: (H, W) bool ground-truth
    cells of the goal object (simulation only: for relabelling, evaluation and tests, never as policy input);
    search: the episode's target memory (pg_policy.perception.target_memory.TargetSearch), set by the episode
    protocol before the policy sees the observation (None from the environment itself)."""

    heightmap: Heightmap
    target: str
    truth_target: np.ndarray
    sim_time: float
    search: Any = None


@dataclass(frozen=True)
class StepResult:
    primitive: str
    executed: bool  # the motion ran to completion (False when refused or timed out)
    refused: bool  # the request was refused before anything moved
    grasped: bool  # fingers not closed after lifting (grasps only)
    target_grasped: bool
    grasped_color: str | None  # palette name of the object grasped (ground truth), None if none
    message: str
    sim_time: float  # simulated seconds the primitive took


class SimEnv:
    """One simulated cell. Not thread-safe; use one per process. Call close() or use `with`. `sim_mode`: ``fast``
    (default) or ``faithful`` (pg_sim.world.sim_mode); `colours`: the colour variant every reset paints
    (pg_sim.world.recolour: ``unique`` (default: the scene's own colours), ``repeated``, ``same``); `sensor`: the
    camera's sensor profile (pg_sim.world.sensor_model: ``perfect`` (default), ``d435``, ``d415`` or a YAML path),
    re-seeded with the seed of every reset (its pose error too); `calibrate`: every reset first calibrates the camera
    in the empty world (pg_learning.environment.sim_calibration, `calibration` keeps the latest) and the heightmaps
    then assume the calibrated pose, as a real cell after `calibrate.launch`. Raises ValueError for an unknown mode,
    variant or profile."""

    def __init__(self, geometry: Geometry | None = None, gui: bool = False, sim_mode: str = DEFAULT_SIM_MODE,
                 colours: str = UNIQUE, sensor: str = PERFECT, calibrate: bool = False) -> None:
        self.colours = check_mode(colours)
        self.calibrate = calibrate
        self.calibration: Any = None  # the latest pg_learning.environment.sim_calibration.SimCalibration
        self.geometry = geometry or load()
        self._world_args = (gui, sim_mode, sensor)
        self.world = World(self.geometry, gui=gui, mode=sim_mode, sensor=sensor)
        self.executor = PrimitiveExecutor(self.world, remove_grasped=True)
        self.target = "green"
        self._used = False  # whether the world has held a scene (then a reset starts from a new one)

    def close(self) -> None:
        self.world.close()

    def __enter__(self) -> SimEnv:
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()

    def reset(self, scene: Any, seed: int = 0) -> EnvObservation:
        """Load a scene: a SceneSpec, a shipped name/YAML path, or a generated family ``<family>-N`` dropped from
        `seed` (random-N, dense-N, novel-N, novel-packed-N, mixed-N, train-...: pg_sim.world.scene_families);
        then paint it in the colour variant `colours` drawn from `seed` (nothing for ``unique``). `target` is the
        target's colour name after painting. The camera's sensor model restarts from `seed`.

        Every reset but the first starts from a new World (25 ms; a GUI world is kept): PyBullet's broadphase and
        contact caches keep the history of earlier scenes, so the same seed dropped into a used world settled into
        another arrangement. A scene is thus a function of (scene, seed) alone, whatever ran before it."""

        self._fresh_world()
        self.world.camera.pose = self.world.camera.spec.pose  # a kept (GUI) world's camera forgets a calibration
        self.world.camera.seed_sensor(seed)
        if self.calibrate:
            self._calibrate()
        if isinstance(scene, SceneSpec):
            self.world.load_scene(scene)
        elif parse_generated(str(scene)):
            generate_scene(self.world, str(scene), seed)
        else:
            self.world.load_scene(load_scene(find_scene(str(scene))))
        if self.colours != UNIQUE:
            recolour(self.world, self.colours, seed)
        self.target = self.world.scene.target if self.world.scene else "green"
        return self.observe()

    def _calibrate(self) -> None:
        """Calibrate the camera of the (empty) world and make the heightmaps assume the calibrated pose; the camera
        still renders from its true one. Raises hand_eye.CalibrationFailed."""
        from pg_learning.environment.sim_calibration import calibrate_camera

        self.calibration = calibrate_camera(self.world)
        self.world.camera.pose = np.asarray(self.calibration.result.world_camera, dtype=np.float64).copy()

    def _fresh_world(self) -> None:
        """Replace a used world by a new one of the same arguments (not in GUI mode: its window would close)."""
        gui, sim_mode, sensor = self._world_args
        if self._used and not gui:
            self.world.close()
            self.world = World(self.geometry, gui=False, mode=sim_mode, sensor=sensor)
            self.executor = PrimitiveExecutor(self.world, remove_grasped=True)
        self._used = True

    def observe(self) -> EnvObservation:
        obs = self.world.observe()
        labels = self.world.label_heightmap(obs.frame)
        tid = self.world.target_id
        truth = labels == tid if tid is not None else np.zeros(labels.shape, dtype=bool)
        return EnvObservation(obs.heightmap, self.target, truth, obs.sim_time)

    def retarget(self, color_name: str) -> bool:
        """Make the object of `color_name` the goal (relabelling); False if no single object has that colour."""

        hits = [b for b, spec in self.world.objects.items() if nearest_color_name(spec.color) == color_name]
        if len(hits) != 1:
            return False
        self.world.target_id = hits[0]
        self.target = color_name
        return True

    def object_colors(self) -> list[str]:
        """Palette names of the objects present (ground truth)."""

        return [nearest_color_name(spec.color) for spec in self.world.objects.values()]

    def target_present(self) -> bool:
        return self.world.target_id is not None

    def target_outside(self) -> bool | None:
        """Ground truth: whether the target body's position lies outside the workspace box in x or y, or below its
        floor (fallen off the table); None when the world holds no target body (e.g. it was lifted and removed)."""
        tid = self.world.target_id
        if tid is None or tid not in self.world.objects:
            return None
        x, y, z = (float(v) for v in self.world.object_poses()[tid][:3])
        ws = self.geometry.workspace
        return not (ws.x[0] <= x <= ws.x[1] and ws.y[0] <= y <= ws.y[1]) or z < ws.z[0]

    def step(self, primitive: str, x: float, y: float, z: float, yaw: float) -> StepResult:
        """Execute one primitive at TCP (x, y, z) m, yaw rad in `world`."""

        action = {"grasp": self.executor.grasp, "push": self.executor.push}
        if primitive not in action:
            raise ValueError(f"unknown primitive '{primitive}' (grasp, push)")
        specs = dict(self.world.objects)
        try:
            res = action[primitive](x, y, z, yaw)
        except PrimitiveRefused as exc:
            return StepResult(primitive, False, True, False, False, None, str(exc), 0.0)
        color = nearest_color_name(specs[res.grasped_object].color) if res.grasped_object is not None else None
        return StepResult(primitive, res.executed, False, res.grasped, res.target_grasped, color, res.message,
                          res.sim_time)
