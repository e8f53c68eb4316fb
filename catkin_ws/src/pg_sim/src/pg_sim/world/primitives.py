"""Grasp and push primitives performed by the simulated arms (DESIGN.md section 4), without ROS.

Inputs are TCP targets in `world`: (x, y, z) in metres and yaw in rad (fingers close along, and pushes travel
along, (cos yaw, sin yaw)). A request outside the workspace box, or unreachable by every allowed arm, raises
PrimitiveRefused before anything moves. Execution is bounded by the primitives.time_budget of simulated time.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass

import numpy as np
import pybullet as p

from pg_sim.robot.arm_driver import ArmDriver, MotionTimeout
from pg_sim.world.transit import arm_links, transit
from pg_sim.world.world import World

# Contact solver iterations while the jaw closes and lifts in every grasp (the world keeps 50 otherwise). Two 40 N
# finger motors squeezing a light object (5-20 g: thin flat things, pens, small parts) do not converge in 50
# iterations: the pads sink into it and slide over it, whatever the grasp height (a lone 10 g cube 20 mm wide and
# 40 mm tall, grasped at its centre with the fingertips at grasp_min_z, slips out with 50 and is lifted with 300;
# held-out thin, rod and small objects at their centre: 15 of 40 lifted with 50, 39 with 300).
SQUEEZE_SOLVER_ITERATIONS = 300
# Longest opening of the fingers at home (s, ArmDriver.gripper's max_time): the objects' settling time after a
# kinematic return home covers it too.
GRIPPER_OPEN_TIME = 0.8


class PrimitiveRefused(ValueError):
    """The request is invalid (outside the workspace, unreachable, unknown arm); nothing moved."""


@dataclass(frozen=True)
class PrimitiveResult:
    primitive: str           # "grasp" | "push"
    arm: str
    executed: bool           # the motion completed within its time budget
    grasped: bool            # grasp only: fingers not fully closed after lifting
    grasped_object: int | None  # body id of the object held (ground truth), None if none
    target_grasped: bool
    sim_time: float          # simulated seconds spent
    message: str


@dataclass(frozen=True)
class _Plan:
    arm: str
    approach: list[np.ndarray]  # joint path home -> pre-pose (joint-space transit)
    cartesian: list[list[np.ndarray]]  # joint paths of straight-line Cartesian polylines, in order
    lengths: list[list[float]]  # Cartesian length (m) of each step in each segment


class PrimitiveExecutor:
    """Plans with IK (choosing the closest arm that reaches every waypoint) and executes under physics. In the
    world's fast mode (pg_sim.world.sim_mode) the free-space joint moves are kinematic when clear of objects."""

    def __init__(self, world: World, remove_grasped: bool = True) -> None:
        self.world_ = world
        self.geo_ = world.geometry
        self.prims_ = world.geometry.primitives
        self.remove_grasped_ = remove_grasped
        self.links_: dict[str, tuple[int, ...]] = {}  # arm -> its links (collision checks of kinematic transit)
        # called after every simulation tick of a push's stroke (the closed fingers travelling along the push), e.g.
        # to watch the scene while the push goes on; it must not move anything
        self.stroke_watch: Callable[[], None] | None = None

    # -- public ------------------------------------------------------------------------------------------------
    def grasp(self, x: float, y: float, z: float, yaw: float, arm: str = "") -> PrimitiveResult:
        pr = self.prims_
        target = np.array([x, y, z])
        pre = target + [0, 0, pr.approach_height]
        lift = target + [0, 0, pr.lift_height]
        self._check_workspace({"grasp point": target, "pre-grasp pose": pre, "lift pose": lift})
        plan = self._plan(arm, yaw, pre, [[self._above(pre), pre, target], [target, lift]])
        return self._run(plan, "grasp")

    def push(self, x: float, y: float, z: float, yaw: float, arm: str = "") -> PrimitiveResult:
        pr = self.prims_
        start = np.array([x, y, z])
        pre = start + [0, 0, pr.approach_height]
        self._check_workspace({"push start": start, "pre-push pose": pre})
        end = start + pr.push_length * np.array([np.cos(yaw), np.sin(yaw), 0.0])
        b = self.geo_.workspace.bounds
        end[:2] = np.clip(end[:2], b[:2, 0], b[:2, 1])  # as VPG: the push end is clipped to the workspace
        post = end + [0, 0, pr.approach_height]
        plan = self._plan(arm, yaw, pre, [[self._above(pre), pre, start], [start, end], [end, post]])
        return self._run(plan, "push")

    # -- planning ----------------------------------------------------------------------------------------------
    def _above(self, pre: np.ndarray) -> np.ndarray:
        """The transit point above the pre-pose (free-space moves happen at transit_height)."""
        return np.array([pre[0], pre[1], max(self.prims_.transit_height, pre[2])])

    def _check_workspace(self, points: dict[str, np.ndarray]) -> None:
        ws = self.geo_.workspace
        for what, pt in points.items():
            if not ws.contains(pt):
                raise PrimitiveRefused(
                    f"{what} ({pt[0]:.3f}, {pt[1]:.3f}, {pt[2]:.3f}) m is outside the workspace "
                    f"x {list(ws.x)} y {list(ws.y)} z {list(ws.z)}"
                )

    def _arm_order(self, arm: str, xy: np.ndarray) -> list[str]:
        arms = self.geo_.robot.arms
        if arm:
            if arm not in arms:
                raise PrimitiveRefused(f"unknown arm '{arm}' (known: {', '.join(arms)})")
            return [arm]
        return sorted(arms, key=lambda a: float(np.linalg.norm(np.array(arms[a].xyz[:2]) - xy)))

    def _plan(self, arm: str, yaw: float, pre: np.ndarray, segments: list[list[np.ndarray]]) -> _Plan:
        reasons = []
        for name in self._arm_order(arm, pre[:2]):
            plan = self._plan_arm(name, yaw, segments)
            if plan is not None:
                return plan
            reasons.append(name)
        raise PrimitiveRefused(
            f"pose ({pre[0]:.3f}, {pre[1]:.3f}) yaw {np.degrees(yaw):.1f} deg is unreachable by arm(s) "
            f"{', '.join(reasons)} (no IK solution along the straight-line path)"
        )

    def _plan_arm(self, arm: str, yaw: float, segments: list[list[np.ndarray]]) -> _Plan | None:
        """IK along each polyline (every waypoint_step m), seeded from the previous waypoint; None if any fails."""
        ik, step = self.world_.ik, self.prims_.waypoint_step
        current = self.world_.arms[arm].joints()
        q = ik.solve(arm, segments[0][0], yaw, np.array(self.geo_.robot.arms[arm].home))
        if q is None:
            return None
        paths, lengths = [], []
        for polyline in segments:
            path, seg_len = [q], []
            for a, b in zip(polyline[:-1], polyline[1:], strict=True):
                n = max(1, int(np.ceil(np.linalg.norm(b - a) / step)))
                for i in range(1, n + 1):
                    q = ik.solve(arm, a + (b - a) * (i / n), yaw, q)
                    if q is None or np.abs(q - path[-1]).max() > 0.5:  # unreachable or a wrist flip mid-line
                        return None
                    path.append(q)
                    seg_len.append(float(np.linalg.norm(b - a)) / n)
            paths.append(path)
            lengths.append(seg_len)
        return _Plan(arm=arm, approach=[current, paths[0][0]], cartesian=paths, lengths=lengths)

    # -- execution ---------------------------------------------------------------------------------------------
    def _run(self, plan: _Plan, primitive: str) -> PrimitiveResult:
        world, driver = self.world_, self.world_.arms[plan.arm]
        g, speed = self.geo_.gripper, self.prims_.cartesian_speed
        t0 = world.sim_time
        driver.set_deadline(t0 + self.prims_.time_budget)
        grasped, held, message = False, None, "ok"
        lifted: list[int] = []  # body ids in the closed jaw after the lift (grasp only)
        try:
            opening = g.max_opening if primitive == "grasp" else 0.0
            driver.command_gripper(opening)
            self._free_move(driver, plan.arm, plan.approach, opening)
            guard = self._descent_guard(driver, primitive)
            reached = driver.follow(plan.cartesian[0], [length / speed for length in plan.lengths[0]], stop=guard)
            if primitive == "grasp":
                with self._squeeze():
                    driver.gripper(0.0)
                    lift = plan.cartesian[1] if reached else self._from_here(driver, plan.cartesian[1:2])[0]
                    driver.follow(lift, [length / speed for length in plan.lengths[1]])
                    grasped = driver.opening() > g.closed_threshold
                    lifted = self._held_objects(driver) if grasped else []
                held = self._credited(lifted)
                message = "grasped" if grasped else "nothing grasped: fingers closed"
                if not grasped:  # release at the lift pose: what the closed jaw snagged falls back where it was
                    driver.gripper(g.max_opening)
            else:
                pushing, after = plan.cartesian[1:], plan.lengths[1:]
                if not reached:  # a guarded descent stopped above the planned start: push from that height
                    pushing = self._from_here(driver, pushing)  # the stroke and the retreat
                driver.follow(pushing[0], [length / self.prims_.push_speed for length in after[0]],
                              tick=self.stroke_watch)
                driver.follow(pushing[1], [length / speed for length in after[1]])
                message = "pushed"
            executed = True
        except MotionTimeout as exc:
            executed, message = False, str(exc)
        target_grasped = held is not None and held == world.target_id
        for body in lifted if self.remove_grasped_ else []:  # everything lifted leaves the scene
            world.remove_object(body)
        self._go_home(driver, plan.arm)
        return PrimitiveResult(primitive, plan.arm, executed, grasped, held, target_grasped,
                               world.sim_time - t0, message)

    @contextmanager
    def _squeeze(self) -> Iterator[None]:
        """Run the block with at least SQUEEZE_SOLVER_ITERATIONS contact solver iterations, then restore the world's
        setting."""
        client = self.world_.client
        before = int(p.getPhysicsEngineParameters(physicsClientId=client)["numSolverIterations"])
        p.setPhysicsEngineParameter(numSolverIterations=max(before, SQUEEZE_SOLVER_ITERATIONS), physicsClientId=client)
        try:
            yield
        finally:
            p.setPhysicsEngineParameter(numSolverIterations=before, physicsClientId=client)

    def _descent_guard(self, driver: ArmDriver, primitive: str) -> Callable[[], bool] | None:
        """Stop condition of the descent: for a grasp, the objects press up on the fingers with more than
        primitives.grasp_stop_force (N); for a push, on the fingers and the palm with more than
        primitives.push_stop_force (N). None (no guard) when that limit is 0."""
        if primitive == "grasp":
            limit, palm = self.prims_.grasp_stop_force, False
        else:
            limit, palm = self.prims_.push_stop_force, True
        if limit <= 0:
            return None
        return lambda: driver.finger_lift_force(self.world_.objects, palm=palm) > limit

    @staticmethod
    def _from_here(driver: ArmDriver, paths: list[list[np.ndarray]]) -> list[list[np.ndarray]]:
        """The planned paths that follow the descent, shifted by where a guarded descent stopped (the joints now
        minus the first path's start): each keeps its length in joint space, so a lift rises by the planned lift
        height from the stop point and a push travels its planned length at the stop height (approximately: the
        shift is small next to the paths)."""
        shift = driver.joints() - paths[0][0]
        return [[q + shift for q in path] for path in paths]

    def _held_objects(self, driver: ArmDriver) -> list[int]:
        """Body ids of the objects the closed jaw lifted (ground truth), sorted: every object touching a finger
        whose lowest point rose above half the lift height (several when the jaw clamped neighbours together);
        when none did, the old contact rule: the lowest id touching both fingers, else either; [] if none."""
        world = self.world_
        touching = []
        for finger in driver.arm.fingers:
            pts = p.getContactPoints(bodyA=world.robot.body, linkIndexA=finger, physicsClientId=world.client)
            touching.append({c[2] for c in pts if c[2] in world.objects})
        either = touching[0] | touching[1]
        clearance = 0.5 * self.prims_.lift_height  # m above the table (z = 0 in `world`)
        raised = sorted(b for b in either if p.getAABB(b, physicsClientId=world.client)[0][2] > clearance)
        if raised:
            return raised
        pick = (touching[0] & touching[1]) or either
        return [min(pick)] if pick else []

    def _credited(self, lifted: list[int]) -> int | None:
        """The grasped object a result reports: the target when it is among `lifted` (it left the table between
        the fingers, with or without a neighbour), else the lowest id; None if nothing was lifted."""
        if self.world_.target_id in lifted:
            return self.world_.target_id
        return lifted[0] if lifted else None

    def _free_move(self, driver: ArmDriver, arm: str, path: list[np.ndarray], opening: float,
                   settle_extra: float = 0.0) -> bool:
        """A joint-space move through free space with the fingers going to `opening` (m): kinematic in the fast
        mode when clear of every object (pg_sim.world.transit; then physics until the objects rest, at most the
        move's duration + `settle_extra` s), else simulated. True when it was kinematic."""
        mode = self.world_.mode
        if mode.kinematic_transit:
            links = self.links_.setdefault(arm, arm_links(self.world_, arm))
            settle = driver.path_duration(path, self.world_.time_step) + settle_extra
            if transit(self.world_, driver, path, links, mode, opening, settle):
                return True
        driver.follow(path)
        return False

    def _go_home(self, driver: ArmDriver, arm: str) -> None:
        home = np.array(self.geo_.robot.arms[arm].home)
        driver.set_deadline(self.world_.sim_time + self.prims_.time_budget)
        try:
            opening = self.geo_.gripper.max_opening
            if not self._free_move(driver, arm, [driver.joints(), home], opening, settle_extra=GRIPPER_OPEN_TIME):
                driver.gripper(opening)
        except MotionTimeout:
            driver.reset(home, self.geo_.gripper.max_opening)  # recovery after a stuck arm (sim only)
