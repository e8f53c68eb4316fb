"""The simulated robot cell as a real-time-ish device (no ROS): the core of the rospy sim node.

`SimRuntime` owns a `World` and, one fixed physics step (1/240 s) at a time:
- follows joint trajectories per arm (pg_sim.robot.trajectory: JointTrajectory semantics, position control within the
  joint velocity limit) and gripper opening commands (metres, clamped to [0, max_opening]);
- reports what is due at this sim time: /clock ticks, joint states, camera captures (organised cloud included), the
  ground-truth scene state with object markers;
- resets to a shipped scene name, a scene YAML file or ``random`` N objects from a seed, validating first (scene
  limits, allowed folders: pg_sim.runtime.reset_request) and answering success only once the scene is at rest with
  its target in the workspace (pg_sim.runtime.scene_swap); a refused reset changes nothing; a reset while an arm
  executes a trajectory is refused ("busy"); ``scene_resets`` counts the successful resets;
- starts every reset from a new world (pg_sim.world.world: PyBullet frees the memory of shapes and removed bodies
  only with the world, and a used world's broadphase history changes how a scene settles), so its memory stays flat
  across resets and a (scene, seed) gives the same scene every time; sim time carries on; a refused reset puts
  the previous objects back in the new world (not with ``gui``: one window, reused);
- paces sim time against wall time (`Pacer`): as fast as possible (or at most ``real_time_factor``) while something
  moves, ``idle_real_time_factor`` (default real time) while nothing does, so an idle sim sleeps.

Threading: the ``submit_*`` methods may be called from any thread (ROS callbacks); they only enqueue. Everything else
(and PyBullet, which is not thread-safe) belongs to the thread that calls `step()`.

Objects that fall off the table, or rest outside the workspace after a gripper released them, are left where they
are (the controller drops grasped objects at the home pose, outside the workspace). An object that has fallen below
the table (pg_sim.runtime.object_activity.FALLEN_Z) is frozen there (made static) so it does not fall forever and
keep the sim busy.
"""

from __future__ import annotations

import queue
import textwrap
import time
from dataclasses import replace

import numpy as np
import pybullet as p

from pg_core.geometry import Geometry
from pg_core.heap_trim import release_free_memory
from pg_sim.robot.trajectory import JointTrajectory, TrajectoryError
from pg_sim.runtime.arm_channel import ArmChannel
from pg_sim.runtime.object_activity import freeze_fallen, objects_moving
from pg_sim.runtime.reset_request import resolve_reset
from pg_sim.runtime.runtime_types import (
    CameraCapture,
    JointStateData,
    ObjectState,
    PendingReset,
    ResetRequest,
    ResetResult,
    RuntimeConfig,
    SceneState,
    StepOutput,
)
from pg_sim.runtime.scene_swap import swap_scene
from pg_sim.scenes.colors import color_name, nearest_color_name, rgba
from pg_sim.scenes.scene import SceneError, SceneSpec
from pg_sim.scenes.scene_folders import AllowedFolders
from pg_sim.world.pacer import Pacer, Periodic
from pg_sim.world.sensor_data import CloudBuilder, MarkerPart, ObjectMarker, depth_with_nan, marker_parts, pose_parts
from pg_sim.world.world import World

ARM_SETTLE_TOL = 2e-3    # rad: after a trajectory the arm counts as moving until within this of its reference
ARM_SETTLE_MAX = 1.0     # s: ... or for at most this long (an arm pressing on an object may never get there)
GRIPPER_MIN_BUSY = 0.05  # s after a gripper command during which it counts as moving (fingers still accelerating)
GRIPPER_MAX_BUSY = 2.0   # s: a gripper stops counting as moving after this long, stalled or not
MAX_START_DELAY = 10.0   # s: a trajectory stamped further in the future is refused (a wall-clock stamp, surely)
CAMERA_REUSE_MAX = 5.0   # s: an unchanged scene re-uses its last render for at most this long
MAX_MESSAGE = 600        # characters: longest reset answer (longer ones are cut)


class SimRuntime:
    """See the module docstring. Construct, then call `step()` in a loop from one thread; `close()` at the end."""

    def __init__(self, config: RuntimeConfig | None = None, geometry: Geometry | None = None,
                 pacer: Pacer | None = None) -> None:
        self.config = cfg = config or RuntimeConfig()
        # the initial scene is the operator's (a parameter): any path; raises SceneError: no world yet
        first = resolve_reset(ResetRequest(cfg.scene, cfg.num_objects, cfg.seed), cfg.limits)
        self.folders = AllowedFolders.default(cfg.scene_folders)
        self.scene_resets = 0
        self.world = self._make_world(geometry, cfg.gui)
        self.worlds_built = 1  # worlds this runtime has made (the first one included)
        self.geometry = self.world.geometry
        self.pacer = pacer or Pacer(cfg.real_time_factor, cfg.idle_real_time_factor)
        self.arms = {name: ArmChannel(name, self.world, self.geometry) for name in self.geometry.robot.arms}
        self.commands_: queue.SimpleQueue[tuple] = queue.SimpleQueue()
        self.frozen_: set[int] = set()
        self.marker_parts_: dict[int, list[MarkerPart]] = {}
        self.cloud_builder_ = CloudBuilder(self.geometry.camera.intrinsics, self.geometry.camera.width,
                                           self.geometry.camera.height)
        self.clock_ = Periodic(cfg.clock_rate)
        self.joint_state_ = Periodic(cfg.joint_state_rate)
        self.camera_ = Periodic(cfg.camera_rate)
        self.scene_state_ = Periodic(cfg.scene_state_rate)
        self.last_capture_: CameraCapture | None = None
        self.last_render_time_ = -np.inf
        self.dirty_ = True  # something may have moved since the last render
        self.busy = False
        self.objects_moving_ = True
        self.step_count = 0
        self.busy_steps = 0
        all_names = [n for a in self.arms.values() for n in (*a.joint_names, *a.finger_names)]
        self.joint_names = tuple(all_names)
        robot = self.world.robot
        self.joint_indices_ = [j for a in robot.arms.values() for j in (*a.joints, *a.fingers)]
        try:
            result = self._apply_reset(*first)
        except Exception:
            self.world.close()
            raise
        if not result.success:
            self.world.close()
            raise SceneError(result.message)

    # -- lifecycle ---------------------------------------------------------------------------------------------
    def close(self) -> None:
        self.world.close()

    def __enter__(self) -> SimRuntime:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    @property
    def sim_time(self) -> float:
        return self.world.sim_time

    # -- thread-safe submissions ---------------------------------------------------------------------------------
    def submit_trajectory(self, arm: str, trajectory: JointTrajectory) -> None:
        self.commands_.put(("trajectory", arm, trajectory))

    def submit_gripper(self, arm: str, opening: float) -> None:
        self.commands_.put(("gripper", arm, float(opening)))

    def submit_reset(self, request: ResetRequest) -> PendingReset:
        pending = PendingReset(request)
        self.commands_.put(("reset", "", pending))
        return pending

    # -- direct commands (stepping thread only) ----------------------------------------------------------------
    def command_trajectory(self, arm: str, trajectory: JointTrajectory) -> None:
        """Replace the arm's trajectory; raises TrajectoryError / KeyError and changes nothing when refused."""
        if arm not in self.arms:
            raise KeyError(f"unknown arm {arm!r}; arms: {sorted(self.arms)}")
        ahead = trajectory.stamp - self.sim_time
        if ahead > MAX_START_DELAY:
            raise TrajectoryError(f"header.stamp {trajectory.stamp:.3f} s is {ahead:.1f} s after the sim time "
                                  f"{self.sim_time:.3f} s: stamp with sim time (/use_sim_time) or 0 for 'now'")
        a = self.arms[arm]
        a.follower.set_trajectory(trajectory, self.sim_time)
        if not a.follower.active:  # empty trajectory: stop where the arm is now
            a.follower.stop(hold=a.driver.joints())
        a.tracking = True

    def command_gripper(self, arm: str, opening: float) -> float:
        """Move the arm's fingers towards ``opening`` m (clamped to [0, max_opening]); returns the clamped value."""
        if arm not in self.arms:
            raise KeyError(f"unknown arm {arm!r}; arms: {sorted(self.arms)}")
        if not np.isfinite(opening):
            raise ValueError(f"gripper opening must be finite, got {opening}")
        target = float(np.clip(opening, 0.0, self.geometry.gripper.max_opening))
        a = self.arms[arm]
        a.driver.command_gripper(target)
        a.gripper_target, a.gripper_time = target, self.sim_time
        return target

    def reset(self, request: ResetRequest) -> ResetResult:
        """Load a scene requested from outside (validated first: scene files within the allowed folders and limits;
        on refusal nothing changes); arms homed, grippers open. Refused ("busy") while an arm executes a trajectory.
        The message is at most MAX_MESSAGE characters."""
        executing = [name for name, a in self.arms.items() if a.follower.active]
        if executing:
            return ResetResult(False, f"busy: arm {executing[0]} is executing a trajectory; reset refused, "
                                      "scene unchanged")
        try:
            resolved = resolve_reset(request, self.config.limits, self.folders)
        except (SceneError, ValueError, OSError, RuntimeError) as e:
            result = ResetResult(False, f"reset refused, scene unchanged: {e}")
        else:
            result = self._apply_reset(*resolved)
        if result.success:
            self.scene_resets += 1
            result = replace(result, resets=self.scene_resets)
        return replace(result, message=textwrap.shorten(result.message, MAX_MESSAGE, placeholder=" [...]"))

    # -- stepping ----------------------------------------------------------------------------------------------
    def step(self) -> StepOutput:
        """Apply queued commands, advance physics one step, pace, and report what is due."""
        messages = self._drain()
        now = self.sim_time + self.world.time_step
        for a in self.arms.values():
            q, qd = a.follower.update(now, self.world.time_step)
            a.driver.command(q, qd, self.geometry.robot.joint_velocity_limit)
            if a.tracking and not a.follower.active:  # reference reached the goal: settle
                a.tracking = False
                a.settle_until = now + ARM_SETTLE_MAX
        self.world.step()
        t = self.sim_time
        busy = self._busy(t)
        self.busy = busy
        self.step_count += 1
        self.busy_steps += int(busy)
        if busy:
            self.dirty_ = True
        out = StepOutput(sim_time=t, busy=busy, messages=messages)
        out.clock = self.clock_.due(t)
        if self.joint_state_.due(t):
            out.joint_state = self.joint_state()
        if self.camera_.due(t):
            out.camera = self.capture()
        if self.step_count % 60 == 0:
            freeze_fallen(self.world, self.frozen_)
        if self.scene_state_.due(t):
            out.scene_state = self.scene_state()
            out.markers = self.markers()
        self.pacer.pace(t, busy)
        return out

    def run_for(self, seconds: float) -> list[StepOutput]:
        """Step for ``seconds`` of sim time (tests and tools); returns the outputs that had something due."""
        outs = []
        end = self.sim_time + seconds - 1e-9
        while self.sim_time < end:
            o = self.step()
            if o.joint_state or o.camera or o.scene_state or o.messages:
                outs.append(o)
        return outs

    # -- outputs -----------------------------------------------------------------------------------------------
    def joint_state(self) -> JointStateData:
        states = p.getJointStates(self.world.robot.body, self.joint_indices_, physicsClientId=self.world.client)
        return JointStateData(self.sim_time, self.joint_names, np.array([s[0] for s in states]),
                              np.array([s[1] for s in states]))

    def capture(self, force: bool = False) -> CameraCapture:
        """Render (or, when nothing moved since the last render, re-use it with a new stamp)."""
        t = self.sim_time
        last = self.last_capture_
        if (not force and last is not None and not self.dirty_ and t - self.last_render_time_ < CAMERA_REUSE_MAX):
            cap = CameraCapture(t, last.color, last.depth, last.cloud, last.seq, False, 0.0)
        else:
            t0 = time.perf_counter()
            frame = self.world.capture()
            depth = depth_with_nan(frame.depth)
            cloud = self.cloud_builder_.build(depth, frame.color)
            seq = last.seq + 1 if last is not None else 0
            cap = CameraCapture(t, frame.color, depth, cloud, seq, True, time.perf_counter() - t0)
            self.dirty_ = False
            self.last_render_time_ = t
        self.last_capture_ = cap
        return cap

    def scene_state(self) -> SceneState:
        w = self.world
        ws = self.geometry.workspace
        objects = []
        target_in = False
        for body, spec in w.objects.items():
            pos, quat = p.getBasePositionAndOrientation(body, physicsClientId=w.client)
            inside = ws.contains(np.asarray(pos))
            objects.append(ObjectState(
                name=spec.name, shape=spec.shape, color_name=color_name(spec.color) or nearest_color_name(spec.color),
                rgb=tuple(int(c) for c in spec.color), target=body == w.target_id,  # type: ignore[arg-type]
                position=tuple(float(v) for v in pos), quaternion=tuple(float(v) for v in quat),  # type: ignore[arg-type]
                in_workspace=inside,
            ))
            target_in = target_in or (body == w.target_id and inside)
        scene = w.scene
        return SceneState(self.sim_time, scene.name if scene else "", scene.target if scene and w.target_id is not None
                          else "", target_in, tuple(objects))

    def markers(self) -> list[ObjectMarker]:
        w = self.world
        out: list[ObjectMarker] = []
        for body, spec in w.objects.items():
            pos, quat = p.getBasePositionAndOrientation(body, physicsClientId=w.client)
            out += pose_parts(spec.name, self.marker_parts_.get(body, []), np.asarray(pos), np.asarray(quat),
                              rgba(spec.color))
        return out

    def arm_joints(self, arm: str) -> np.ndarray:
        return self.arms[arm].driver.joints()

    def gripper_opening(self, arm: str) -> float:
        return self.arms[arm].driver.opening()

    # -- internals ---------------------------------------------------------------------------------------------
    def _drain(self) -> list[str]:
        messages = []
        while True:
            try:
                kind, arm, payload = self.commands_.get_nowait()
            except queue.Empty:
                return messages
            try:
                if kind == "trajectory":
                    self.command_trajectory(arm, payload)
                elif kind == "gripper":
                    self.command_gripper(arm, payload)
                elif kind == "reset":
                    try:
                        result = self.reset(payload.request)
                    except Exception as e:  # never leave a service caller waiting
                        result = ResetResult(False, f"reset failed: {type(e).__name__}: {e}")
                    payload.finish(result)
                    if not result.success:
                        messages.append(result.message)
            except (TrajectoryError, KeyError, ValueError) as e:
                messages.append(f"{arm} {kind} command refused: {e}")

    def _apply_reset(self, scene: SceneSpec, generated: bool) -> ResetResult:
        """A reset starts from a new, empty world unless the world is still unused (the first reset) or ``gui`` is on
        (one window): a (scene, seed) then settles the same whatever ran before (a used world keeps its broadphase
        history), and the memory PyBullet keeps of removed bodies and shapes goes with the old world. A refused
        reset gets the previous objects back, at their poses, in another new world (the refused scene's bodies go
        with the world that loaded them)."""
        previous = None
        if not self.config.gui and self.world.bodies_created > 0:
            previous = self.world.snapshot() if self.world.scene is not None else None
            self._renew_world()
        result = swap_scene(self.world, scene, generated, self.config.rest_timeout)
        if not result.success and previous is not None:
            self._renew_world()
            self.world.load_scene(previous, settle=False)
        self._after_scene_change()
        release_free_memory()  # a scene's peak (meshes, settling) does not stay resident
        return result

    def _make_world(self, geometry: Geometry | None, gui: bool) -> World:
        """A world as this runtime's config asks for (the first one and every renewal: one place for the
        arguments)."""
        world = World(geometry, gui=gui, time_step=self.config.time_step)
        if self.config.calibration_board:
            try:
                world.attach_board(self.config.calibration_board)
            except Exception:
                world.close()
                raise
        return world

    def _renew_world(self) -> None:
        """Replace the world by a new, empty one with the same sim time; arms are homed by the reset that follows.
        Raises what World raises, the old world kept."""
        old = self.world
        world = self._make_world(self.geometry, False)
        world.sim_time = old.sim_time
        old.close()
        release_free_memory()
        self.world = world
        self.worlds_built += 1
        self.arms = {name: ArmChannel(name, self.world, self.geometry) for name in self.geometry.robot.arms}
        robot = world.robot
        self.joint_indices_ = [j for a in robot.arms.values() for j in (*a.joints, *a.fingers)]
        self.frozen_.clear()

    def _after_scene_change(self) -> None:
        g = self.geometry
        w = self.world
        w.home()
        for name, a in self.arms.items():
            a.home(np.asarray(g.robot.arms[name].home), g.gripper.max_opening)
        self.frozen_.clear()
        self.marker_parts_ = {b: marker_parts(spec) for b, spec in w.objects.items()}
        self.dirty_ = True
        t = self.sim_time
        for periodic in (self.clock_, self.joint_state_, self.camera_, self.scene_state_):
            periodic.force(t)
        self.pacer.reanchor()

    def _busy(self, t: float) -> bool:
        busy = False
        for a in self.arms.values():
            if a.follower.active:
                busy = True
            elif t < a.settle_until:
                states = p.getJointStates(self.world.robot.body, a.driver.arm.joints, physicsClientId=self.world.client)
                err = np.abs(np.array([s[0] for s in states]) - a.follower.reference).max()
                vel = np.abs(np.array([s[1] for s in states])).max()
                if err < ARM_SETTLE_TOL and vel < 10 * ARM_SETTLE_TOL:
                    a.settle_until = -1.0
                else:
                    busy = True
            since = t - a.gripper_time
            if since < GRIPPER_MAX_BUSY:
                if since < GRIPPER_MIN_BUSY:
                    busy = True
                else:
                    fingers = p.getJointStates(self.world.robot.body, a.driver.arm.fingers,
                                               physicsClientId=self.world.client)
                    if max(abs(s[1]) for s in fingers) > 1e-3:
                        busy = True
                    else:
                        a.gripper_time = -np.inf  # stopped (reached or stalled)
        if self.step_count % 4 == 0:  # objects every 4th step (1/60 s); the result holds in between
            self.objects_moving_ = objects_moving(self.world, self.frozen_)
        return busy or self.objects_moving_
