"""The PyBullet world: table, dual UR5e with grippers, RGB-D camera and scene objects (no ROS).

Frame: PyBullet's world frame IS `world` (table surface at z = 0, workspace centre at the origin).
Time: fixed physics step `time_step` (s); `sim_time` counts simulated seconds since construction.

Memory: PyBullet returns the memory of a collision or visual shape only when its client disconnects
(``removeCollisionShape`` keeps most of it; visual shapes cannot be removed), and keeps about 6 KB of every body
after ``removeBody``. Objects therefore share their shapes: a world builds the shapes of a `shape_key` once and
every later object of that key reuses them (PyBullet shares a shape between bodies; colour, mass and friction are
per body). An owner that loads scenes for a long time (pg_sim.runtime.sim_runtime) starts each from a new world,
which frees all of it.
"""

from __future__ import annotations

import os
from dataclasses import dataclass, replace

import numpy as np
import pybullet as p

from pg_core import heightmap as hm
from pg_core.charuco_board import DEFAULT_BOARD, BoardSpec
from pg_core.geometry import Geometry, load
from pg_sim.robot.arm_driver import ArmDriver
from pg_sim.robot.ik import IkSolver
from pg_sim.robot.robot_model import load_robot
from pg_sim.scenes.meshes import collision_file
from pg_sim.scenes.objects import build_shape, object_pose, spawn_object
from pg_sim.scenes.scene import ObjectSpec, SceneSpec
from pg_sim.world.calibration_board import SimBoard
from pg_sim.world.camera import Frame, SimCamera
from pg_sim.world.sensor_model import PERFECT, SensorProfile, make_sensor
from pg_sim.world.sim_mode import DEFAULT_SIM_MODE, SimMode, get_sim_mode
from pg_sim.world.static_table import detach_table

ShapeKey = tuple[object, ...]
ShapeIds = tuple[int, int, float]  # collision id, visual id, mass (kg) as pg_sim.scenes.objects.build_shape


def shape_key(spec: ObjectSpec) -> ShapeKey:
    """What an object's PyBullet shapes depend on: the registry shape and size, or for a mesh its file (path, and
    size and modification time of it and of its collision companion) and scale. Equal keys give equal shapes."""
    if spec.shape != "mesh":
        return (spec.shape, None if spec.size is None else tuple(float(v) for v in spec.size))
    mesh = str(spec.mesh or "")
    return ("mesh", mesh, tuple(float(v) for v in spec.scale), _file_stamp(mesh),
            _file_stamp(str(collision_file(mesh))) if mesh else None)


def _file_stamp(path: str) -> tuple[int, int] | None:
    """(size in bytes, modification time in ns) of a file, None when it cannot be read."""
    try:
        st = os.stat(path)
    except OSError:
        return None
    return (st.st_size, st.st_mtime_ns)


# Points on the robot body at or above this height (m, `world` z) are the robot's own (arms, grippers); below it
# lies the table top, which the robot's description carries as a visual link.
ROBOT_FILTER_Z_M = 0.002


@dataclass(frozen=True)
class Observation:
    frame: Frame
    heightmap: hm.Heightmap
    sim_time: float


class World:
    """A simulated cell. Use as a context manager or call close(); `gui=True` opens the PyBullet window. `mode`:
    a simulation mode of pg_sim.world.sim_mode (``fast`` or ``faithful``); raises ValueError for another. `sensor`:
    the camera's sensor profile (pg_sim.world.sensor_model: ``perfect``, ``d435``, ``d415`` or a YAML path) seeded
    with `sensor_seed`; raises ValueError for an unknown one."""

    def __init__(self, geometry: Geometry | None = None, gui: bool = False, time_step: float = 1 / 240,
                 solver_iterations: int = 50, mode: str | SimMode = DEFAULT_SIM_MODE,
                 sensor: str | SensorProfile = PERFECT, sensor_seed: int = 0) -> None:
        camera_sensor = make_sensor(sensor, sensor_seed)  # ValueError before anything is built
        self.mode = get_sim_mode(mode)
        self.geometry = geometry or load()
        self.client = p.connect(p.GUI if gui else p.DIRECT)
        p.setGravity(0, 0, -9.81, physicsClientId=self.client)
        p.setPhysicsEngineParameter(fixedTimeStep=time_step, numSolverIterations=solver_iterations,
                                    physicsClientId=self.client)
        self.time_step = time_step
        self.sim_time = 0.0
        self.robot = load_robot(self.client, self.geometry)
        self.table_body = detach_table(self.client, self.robot.body) if self.mode.static_table else None
        self.ik = IkSolver(self.geometry)
        self.arms = {
            name: ArmDriver(self.client, self.robot.body, idx, self.geometry, self.step)
            for name, idx in self.robot.arms.items()
        }
        self.camera = SimCamera(self.client, self.geometry.camera, sensor=camera_sensor)
        self.objects: dict[int, ObjectSpec] = {}
        self.shapes_: dict[ShapeKey, ShapeIds] = {}  # shapes built in this client, per shape_key
        self.bodies_created = 0  # objects spawned since construction (removed ones included)
        self.target_id: int | None = None
        self.scene: SceneSpec | None = None
        self.board: SimBoard | None = None  # a calibration board on a tool (attach_board)
        self.home()

    # -- lifecycle ---------------------------------------------------------------------------------------------
    def close(self) -> None:
        """Disconnect the physics client. The arm drivers go too: each holds this world's `step`, a reference
        cycle that would keep a closed world, its camera's last images included, until Python's cyclic garbage
        collector happened to run (a node that renews its world every reset would hold a varying number)."""
        self.detach_board()
        self.ik.close()
        self.arms.clear()
        if p.isConnected(self.client):
            p.disconnect(self.client)

    def __enter__(self) -> World:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def step(self) -> float:
        p.stepSimulation(physicsClientId=self.client)
        self.sim_time += self.time_step
        return self.sim_time

    def home(self) -> None:
        """Teleport both arms to their home configuration with open grippers (scene setup only)."""
        for name, driver in self.arms.items():
            driver.reset(self.geometry.robot.arms[name].home, self.geometry.gripper.max_opening)

    # -- objects -----------------------------------------------------------------------------------------------
    def clear_objects(self) -> None:
        for body in list(self.objects):
            p.removeBody(body, physicsClientId=self.client)
        self.objects.clear()
        self.target_id = None
        self.scene = None

    def add_object(self, spec: ObjectSpec) -> int:
        """Spawn ``spec``; returns its body id. Its ``friction`` (when not None) replaces the default lateral
        friction; without one, the body is exactly as spawn_object makes it. Shapes are built once per
        `shape_key` and shared (module docstring)."""
        key = shape_key(spec)
        shapes = self.shapes_.get(key)
        if shapes is None:
            shapes = build_shape(self.client, spec)
            self.shapes_[key] = shapes
        body = spawn_object(self.client, spec, shapes=shapes)
        self.bodies_created += 1
        if spec.friction is not None:
            p.changeDynamics(body, -1, lateralFriction=float(spec.friction), physicsClientId=self.client)
        self.objects[body] = spec
        if spec.target:
            self.target_id = body
        return body

    def remove_object(self, body: int) -> None:
        p.removeBody(body, physicsClientId=self.client)
        self.objects.pop(body)
        if body == self.target_id:
            self.target_id = None

    def load_scene(self, scene: SceneSpec, settle: bool = True) -> None:
        """Replace all objects by the scene's (arms homed); raises SceneError for specs that cannot be built."""
        self.clear_objects()
        self.home()
        for spec in scene.objects:
            self.add_object(spec)
        self.scene = scene
        if settle:
            self.settle()

    def settle(self, max_time: float = 3.0, min_time: float = 0.2, lin_tol: float = 2e-3,
               ang_tol: float = 2e-2) -> float:
        """Step until every object is at rest (m/s, rad/s tolerances) or max_time passes; returns time stepped."""
        t0 = self.sim_time
        while self.sim_time - t0 < max_time:
            for _ in range(12):
                self.step()
            if self.sim_time - t0 < min_time:
                continue
            if all(self._at_rest(b, lin_tol, ang_tol) for b in self.objects):
                break
        return self.sim_time - t0

    def _at_rest(self, body: int, lin_tol: float, ang_tol: float) -> bool:
        lin, ang = p.getBaseVelocity(body, physicsClientId=self.client)
        return float(np.linalg.norm(lin)) < lin_tol and float(np.linalg.norm(ang)) < ang_tol

    def object_poses(self) -> dict[int, np.ndarray]:
        """Body id -> (x, y, z, roll, pitch, yaw) in world."""
        return {b: object_pose(self.client, b) for b in self.objects}

    def snapshot(self, name: str | None = None) -> SceneSpec:
        """The current objects as a scene (their present poses), e.g. to save a settled random scene."""
        from dataclasses import replace

        poses = self.object_poses()
        objs = tuple(replace(spec, pose=tuple(float(v) for v in poses[b])) for b, spec in self.objects.items())
        base = self.scene
        return SceneSpec(name=name or (base.name if base else "snapshot"), target=base.target if base else "green",
                         objects=objs, family=base.family if base else "snapshot")

    # -- sensing -----------------------------------------------------------------------------------------------
    def attach_board(self, arm: str, spec: BoardSpec = DEFAULT_BOARD) -> SimBoard:
        """Mount the printed calibration board `spec` on `arm`'s tool (pg_core.calibration_poses.board_mount):
        every later capture shows it where the arm holds it (visual only: nothing collides with it). Raises
        ValueError for an unknown arm or when a board is mounted already."""
        if arm not in self.arms:
            raise ValueError(f"calibration board: unknown arm {arm!r}; the arms are {', '.join(self.arms)}")
        if self.board is not None:
            raise ValueError(f"calibration board: one is mounted on the {self.board.arm} arm already")
        self.board = SimBoard(self.client, self.geometry, self.robot.body, self.robot.arms[arm].tool0, arm,
                              spec.image(4000.0), spec.printed_size_m)
        return self.board

    def detach_board(self) -> None:
        """Remove the mounted calibration board (nothing when none is mounted)."""
        if self.board is not None:
            self.board.remove()
            self.board = None

    def capture(self) -> Frame:
        if self.board is not None:
            self.board.follow()
        return self.camera.capture()

    def observe(self, hide_robot: bool = False) -> Observation:
        """Render the camera and project its cloud to the workspace heightmap. hide_robot: drop the points on the
        robot above the table top (arms and grippers, ROBOT_FILTER_Z_M and higher; a robot self-filter), so that
        the cells they hide hold no data (`valid` False) instead of the arm's heights; the frame returned has no
        depth there (0)."""
        frame = self.capture()
        if hide_robot:
            frame = replace(frame, depth=np.where(self.robot_pixels(frame), 0.0, frame.depth).astype(np.float32))
        pts, colors = self.camera.point_cloud(frame)
        heightmap = hm.from_camera_cloud(pts, colors, self.camera.pose, self.geometry)
        return Observation(frame=frame, heightmap=heightmap, sim_time=self.sim_time)

    def robot_pixels(self, frame: Frame) -> np.ndarray:
        """(H, W) bool image mask of the robot's own pixels in `frame`: points on the robot body at or above
        ROBOT_FILTER_Z_M in `world` (arms and grippers; the table top below it is a visual link of that body)."""
        pts, _ = self.camera.point_cloud(frame)
        high = hm.transform_points(pts, self.camera.pose)[:, 2] >= ROBOT_FILTER_Z_M
        return ((frame.segmentation.reshape(-1) == self.robot.body) & high).reshape(frame.depth.shape)

    def object_mask(self, frame: Frame, body: int) -> np.ndarray:
        """Ground-truth (H, W) bool image mask of one object in a captured frame."""
        return frame.segmentation == body

    def label_heightmap(self, frame: Frame) -> np.ndarray:
        """Ground truth: (rows, cols) int64 body id seen at the top of each heightmap cell (-1 where empty)."""
        pts, _ = self.camera.point_cloud(frame)
        world_pts = hm.transform_points(pts, self.camera.pose)
        g = self.geometry
        return hm.project_labels(world_pts, frame.segmentation, g.workspace.bounds, g.heightmap.resolution)
