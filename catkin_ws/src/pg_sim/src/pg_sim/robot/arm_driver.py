"""Drives one simulated arm and its gripper by streaming joint position targets, under physics.

Joint angles in rad, openings in metres (finger-pad distance). Motions respect the UR5e joint speed limit and the
Cartesian tool speed of the geometry config. Every motion is bounded by the caller's sim-time deadline and raises
MotionTimeout when it passes.
"""

from __future__ import annotations

from collections.abc import Callable, Collection, Sequence

import numpy as np
import pybullet as p

from pg_core.geometry import Geometry
from pg_sim.robot.robot_model import ArmIndex


class MotionTimeout(RuntimeError):
    """The motion did not finish before the primitive's sim-time deadline."""


class ArmDriver:
    """Position control of one arm (6 joints) and its two prismatic fingers inside the world's physics client."""

    def __init__(self, client: int, body: int, arm: ArmIndex, geometry: Geometry, step: Callable[[], float]) -> None:
        self.client_ = client
        self.body_ = body
        self.arm = arm
        self.geometry_ = geometry
        self.step_ = step  # advances physics one tick, returns the sim time (s)
        self.dt_ = 0.0
        self.effort_ = list(geometry.robot.joint_effort_limit)
        self.vmax_ = geometry.robot.joint_velocity_limit
        self.deadline_ = float("inf")

    # -- state -------------------------------------------------------------------------------------------------
    def joints(self) -> np.ndarray:
        states = p.getJointStates(self.body_, self.arm.joints, physicsClientId=self.client_)
        return np.array([s[0] for s in states])

    def opening(self) -> float:
        states = p.getJointStates(self.body_, self.arm.fingers, physicsClientId=self.client_)
        return float(states[0][0] + states[1][0])

    def finger_positions(self) -> tuple[float, float]:
        """The two finger joint positions (m)."""
        states = p.getJointStates(self.body_, self.arm.fingers, physicsClientId=self.client_)
        return float(states[0][0]), float(states[1][0])

    def segment_duration(self, q0: np.ndarray, q1: np.ndarray, cartesian_s: float = 0.0, dt: float = 1 / 240) -> float:
        """Simulated seconds `follow` takes from joints q0 to q1 (rad): max(joint distance / 0.9 x the joint speed
        limit, the segment's Cartesian time `cartesian_s`, one step `dt`)."""
        return max(float(np.abs(q1 - q0).max()) / (0.9 * self.vmax_), cartesian_s, dt)

    def path_duration(self, path: Sequence[np.ndarray], dt: float = 1 / 240) -> float:
        """Simulated seconds `follow` takes along a joint-space `path` without Cartesian times."""
        qs = [np.asarray(q, dtype=np.float64) for q in path]
        return sum(self.segment_duration(a, b, dt=dt) for a, b in zip(qs[:-1], qs[1:], strict=True))

    def place(self, q: Sequence[float], opening: float | None, fingers: Sequence[float] | None = None) -> None:
        """Set the joints to `q` (rad) and the fingers to `opening` (m), or to their two positions `fingers`,
        with zero velocity; commands nothing and steps no physics (collision checks of a kinematic transit)."""
        for j, v in zip(self.arm.joints, q, strict=True):
            p.resetJointState(self.body_, j, float(v), physicsClientId=self.client_)
        if opening is not None:
            fingers = (opening / 2, opening / 2)
        for j, v in zip(self.arm.fingers, fingers or (), strict=False):
            p.resetJointState(self.body_, j, float(v), physicsClientId=self.client_)

    def reset(self, q: Sequence[float], opening: float) -> None:
        """Teleport joints and fingers and hold them there: scene setup, and the kinematic free-space moves of the
        fast simulation mode (pg_sim.world.transit), never where the arm could touch an object."""
        for j, v in zip(self.arm.joints, q, strict=True):
            p.resetJointState(self.body_, j, float(v), physicsClientId=self.client_)
        for j in self.arm.fingers:
            p.resetJointState(self.body_, j, opening / 2, physicsClientId=self.client_)
        self._command(np.asarray(q, dtype=np.float64), np.zeros(6))
        self.command_gripper(opening)

    def set_deadline(self, sim_time: float) -> None:
        self.deadline_ = sim_time

    # -- motion ------------------------------------------------------------------------------------------------
    def _command(self, q: np.ndarray, qd: np.ndarray) -> None:
        p.setJointMotorControlArray(
            self.body_, self.arm.joints, p.POSITION_CONTROL, targetPositions=q.tolist(),
            targetVelocities=qd.tolist(), forces=self.effort_, positionGains=[0.3] * 6, velocityGains=[1.0] * 6,
            physicsClientId=self.client_,
        )

    def command(self, q: Sequence[float], qd: Sequence[float], max_velocity: float | None = None) -> None:
        """Stream one joint position (rad) / velocity (rad/s) target to the six motors; does not step physics.

        With ``max_velocity`` (rad/s) the motors never drive a joint faster than that, even while catching up.
        """
        if max_velocity is None:
            self._command(np.asarray(q, dtype=np.float64), np.asarray(qd, dtype=np.float64))
            return
        for j, qi, vi, f in zip(self.arm.joints, q, qd, self.effort_, strict=True):
            p.setJointMotorControl2(
                self.body_, j, p.POSITION_CONTROL, targetPosition=float(qi), targetVelocity=float(vi), force=f,
                positionGain=0.3, velocityGain=1.0, maxVelocity=max_velocity, physicsClientId=self.client_,
            )

    def _tick(self) -> float:
        t = self.step_()
        if t > self.deadline_:
            raise MotionTimeout(f"motion exceeded the primitive time budget at t={t:.2f} s")
        return t

    def follow(self, path: Sequence[np.ndarray], speeds: Sequence[float] | None = None, dt: float = 1 / 240,
               stop: Callable[[], bool] | None = None, tick: Callable[[], None] | None = None) -> bool:
        """Track a joint-space path (first point = current joints) with linear interpolation per segment.

        Segment duration = max(joint distance / joint speed limit, Cartesian length / tool speed) where `speeds`
        gives the Cartesian time (s) of each segment; ends when the joints settle within 2e-3 rad. A guarded
        motion: when `stop()` turns True after a tick, the arm holds where it is and follow returns False; True
        when the path was completed. `tick()`, when given, is called after every tick of the path (an observer:
        it must not move the arm)."""
        qs = [np.asarray(q, dtype=np.float64) for q in path]
        for k in range(1, len(qs)):
            dq = qs[k] - qs[k - 1]
            duration = self.segment_duration(qs[k - 1], qs[k], speeds[k - 1] if speeds else 0.0, dt)
            n = max(1, int(np.ceil(duration / dt)))
            for i in range(1, n + 1):
                self._command(qs[k - 1] + dq * (i / n), dq / duration)
                self._tick()
                if tick is not None:
                    tick()
                if stop is not None and stop():
                    self._command(self.joints(), np.zeros(6))
                    return False
        self.settle(qs[-1])
        return True

    def finger_lift_force(self, bodies: Collection[int], palm: bool = False) -> float:
        """Upward force (N, world +z) that `bodies` exert on the two fingers (and the palm when `palm`) through
        contact: the sum of normal force x the z of the contact normal (which PyBullet gives on the other body,
        pointing at the gripper)."""
        total = 0.0
        for link in (*self.arm.fingers, self.arm.palm) if palm else self.arm.fingers:
            for c in p.getContactPoints(bodyA=self.body_, linkIndexA=link, physicsClientId=self.client_):
                if c[2] in bodies:
                    total += c[9] * c[7][2]
        return total

    def settle(self, q: np.ndarray, tol: float = 2e-3, max_time: float = 0.5, dt: float = 1 / 240) -> bool:
        """Hold q until the joints are within tol (rad) or max_time passes; True when reached."""
        self._command(q, np.zeros(6))
        for _ in range(int(max_time / dt)):
            if np.abs(self.joints() - q).max() < tol:
                return True
            self._tick()
        return False

    def command_gripper(self, opening: float) -> None:
        g = self.geometry_.gripper
        target = float(np.clip(opening, 0.0, g.max_opening)) / 2
        for j in self.arm.fingers:
            p.setJointMotorControl2(
                self.body_, j, p.POSITION_CONTROL, targetPosition=target, force=g.finger_force,
                maxVelocity=g.finger_speed, physicsClientId=self.client_,
            )

    def gripper(self, opening: float, max_time: float = 0.8, dt: float = 1 / 240) -> float:
        """Move the fingers towards `opening` (m) until they reach it or stall; returns the final opening."""
        self.command_gripper(opening)
        last = self.opening()
        still = 0
        for _ in range(int(max_time / dt)):
            self._tick()
            now = self.opening()
            if abs(now - opening) < 5e-4:
                break
            still = still + 1 if abs(now - last) < 2e-5 else 0
            if still >= 6:  # stalled on an object
                break
            last = now
        return self.opening()
