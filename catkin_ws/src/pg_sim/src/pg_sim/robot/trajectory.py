"""Joint trajectories as trajectory_msgs/JointTrajectory means them, and a rate-limited follower (no ROS).

Semantics (those of ros_controllers' joint_trajectory_controller, simplified):
- ``time_from_start`` of each point is relative to the trajectory's start time: the header stamp, or "now" when the
  stamp is zero. Times must be >= 0 and strictly increasing.
- The trajectory starts from the current commanded position (velocity 0) at time 0; a first point at time 0 replaces
  that start state.
- Between two points positions are interpolated linearly, or by a cubic Hermite spline when both points carry
  velocities (accelerations are ignored). After the last point its position is held.
- A point may name a subset of the arm's joints; the others hold their present position. An empty trajectory (no
  points) stops the arm where it is.
- A new trajectory replaces the current one (from the present commanded position: no jump).
- The commanded reference never moves faster than the joint velocity limit: a trajectory asking for more is slowed
  down as a whole (speed scaling, all joints together, the path keeps its shape), it is not rejected.
Invalid trajectories (unknown joint names, wrong lengths, non-finite values, non-increasing times, positions outside
the joint limits) raise TrajectoryError and change nothing.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np


class TrajectoryError(ValueError):
    """A trajectory that cannot be followed; the message says which point / joint and why."""


@dataclass(frozen=True)
class TrajectoryPoint:
    """One waypoint as in trajectory_msgs/JointTrajectoryPoint (empty velocities = none given)."""

    positions: tuple[float, ...]
    time_from_start: float
    velocities: tuple[float, ...] = ()


@dataclass(frozen=True)
class JointTrajectory:
    """Joint names (any order, any subset of an arm's joints) and points; ``stamp`` 0 means "start now"."""

    joint_names: tuple[str, ...]
    points: tuple[TrajectoryPoint, ...]
    stamp: float = 0.0


class Spline:
    """A validated trajectory resolved onto all six joints of one arm, sampled by time since its start."""

    def __init__(self, times: np.ndarray, positions: np.ndarray, velocities: np.ndarray | None) -> None:
        self.times = times            # (K,) s, strictly increasing, times[0] == 0 (the start state)
        self.positions = positions    # (K, n) rad
        self.velocities = velocities  # (K, n) rad/s, or None for linear interpolation everywhere
        self.duration = float(times[-1])

    @property
    def goal(self) -> np.ndarray:
        return self.positions[-1]

    def sample(self, t: float) -> tuple[np.ndarray, np.ndarray]:
        """Desired (position, velocity) at time t (s) since the start; held at the ends."""
        ts = self.times
        if t <= ts[0]:
            return self.positions[0].copy(), np.zeros_like(self.positions[0])
        if t >= ts[-1]:
            return self.positions[-1].copy(), np.zeros_like(self.positions[-1])
        k = int(np.searchsorted(ts, t, side="right")) - 1
        h = ts[k + 1] - ts[k]
        s = (t - ts[k]) / h
        q0, q1 = self.positions[k], self.positions[k + 1]
        if self.velocities is None or np.isnan(self.velocities[k]).any() or np.isnan(self.velocities[k + 1]).any():
            return q0 + s * (q1 - q0), (q1 - q0) / h
        v0, v1 = self.velocities[k] * h, self.velocities[k + 1] * h  # tangents in the unit parameter
        s2, s3 = s * s, s * s * s
        q = (2 * s3 - 3 * s2 + 1) * q0 + (s3 - 2 * s2 + s) * v0 + (-2 * s3 + 3 * s2) * q1 + (s3 - s2) * v1
        dq = (6 * s2 - 6 * s) * q0 + (3 * s2 - 4 * s + 1) * v0 + (-6 * s2 + 6 * s) * q1 + (3 * s2 - 2 * s) * v1
        return q, dq / h


def build_spline(traj: JointTrajectory, arm_joints: Sequence[str], start: np.ndarray,
                 lower: Sequence[float] | None = None, upper: Sequence[float] | None = None,
                 prefix: str = "") -> Spline:
    """Resolve ``traj`` onto ``arm_joints`` (full names) starting from ``start``; raises TrajectoryError.

    Joint names may be given in full (``left_elbow_joint``) or without the arm prefix (``elbow_joint``).
    """
    names = list(arm_joints)
    n = len(names)
    cols: list[int] = []
    for name in traj.joint_names:
        full = name if name in names else prefix + name
        if full not in names:
            raise TrajectoryError(f"unknown joint {name!r}; this arm's joints are {names}")
        if names.index(full) in cols:
            raise TrajectoryError(f"joint {name!r} is named twice")
        cols.append(names.index(full))
    if not traj.points:
        raise TrajectoryError("a trajectory without points stops the arm; use stop() instead")
    if not cols:
        raise TrajectoryError("trajectory has points but no joint names")
    start = np.asarray(start, dtype=np.float64)
    times = [0.0]
    positions = [start.copy()]
    velocities = [np.zeros(n)]
    any_vel = False
    all_vel = True
    prev_t = -1.0
    for k, pt in enumerate(traj.points):
        t = float(pt.time_from_start)
        if not np.isfinite(t) or t < 0.0:
            raise TrajectoryError(f"point {k}: time_from_start must be finite and >= 0, got {t}")
        if t <= prev_t:
            raise TrajectoryError(f"point {k}: time_from_start {t} s is not after the previous point's {prev_t} s")
        prev_t = t
        if len(pt.positions) != len(cols):
            raise TrajectoryError(f"point {k}: {len(pt.positions)} positions for {len(cols)} joint names")
        if pt.velocities and len(pt.velocities) != len(cols):
            raise TrajectoryError(f"point {k}: {len(pt.velocities)} velocities for {len(cols)} joint names")
        vals = np.asarray(pt.positions, dtype=np.float64)
        if not np.isfinite(vals).all():
            raise TrajectoryError(f"point {k}: positions must be finite, got {list(pt.positions)}")
        q = positions[-1].copy()
        q[cols] = vals
        for c in cols:
            if (lower is not None and q[c] < lower[c] - 1e-9) or (upper is not None and q[c] > upper[c] + 1e-9):
                raise TrajectoryError(f"point {k}: {names[c]} = {q[c]:.4f} rad is outside its limits "
                                      f"[{lower[c] if lower else -np.inf:.4f}, {upper[c] if upper else np.inf:.4f}]")
        v = np.zeros(n)
        if pt.velocities:
            vv = np.asarray(pt.velocities, dtype=np.float64)
            if not np.isfinite(vv).all():
                raise TrajectoryError(f"point {k}: velocities must be finite, got {list(pt.velocities)}")
            v[cols] = vv
            any_vel = True
        else:
            all_vel = False
        if t == 0.0:  # replaces the start state
            positions[0], velocities[0] = q, v
            continue
        times.append(t)
        positions.append(q)
        velocities.append(v)
    use_cubic = any_vel and all_vel  # velocities on some points only: linear everywhere
    return Spline(np.asarray(times), np.vstack(positions), np.vstack(velocities) if use_cubic else None)


class TrajectoryFollower:
    """Per-arm reference generator: samples the active spline and rate-limits the commanded reference.

    ``update(now, dt)`` returns the (position, velocity) command for this physics step. ``active`` stays true until
    the trajectory's time has passed and the reference has reached its goal.
    """

    def __init__(self, joint_names: Sequence[str], start: np.ndarray, velocity_limit: float | Sequence[float],
                 lower: Sequence[float] | None = None, upper: Sequence[float] | None = None, prefix: str = "") -> None:
        self.joint_names = tuple(joint_names)
        self.prefix = prefix
        self.lower = list(lower) if lower is not None else None
        self.upper = list(upper) if upper is not None else None
        self.vmax = np.broadcast_to(np.asarray(velocity_limit, dtype=np.float64), (len(self.joint_names),)).copy()
        self.reference = np.asarray(start, dtype=np.float64).copy()
        self.velocity = np.zeros(len(self.joint_names))
        self.spline: Spline | None = None
        self.start_time = 0.0
        self.clock_: float | None = None  # the trajectory's own (speed-scaled) time
        self.velocity_limited = False  # the last trajectory asked for more than the velocity limit somewhere

    @property
    def active(self) -> bool:
        return self.spline is not None

    @property
    def goal(self) -> np.ndarray:
        return self.spline.goal.copy() if self.spline is not None else self.reference.copy()

    def set_trajectory(self, traj: JointTrajectory, now: float) -> None:
        """Replace the current trajectory (validated first; on TrajectoryError nothing changes)."""
        if not traj.points:
            self.stop()
            return
        spline = build_spline(traj, self.joint_names, self.reference, self.lower, self.upper, self.prefix)
        self.spline = spline
        self.start_time = float(traj.stamp) if traj.stamp > 0.0 else float(now)
        self.clock_ = None  # set on the first update
        self.velocity_limited = False

    def stop(self, hold: np.ndarray | None = None) -> None:
        """Drop the trajectory and hold ``hold`` (default: the present reference)."""
        self.spline = None
        if hold is not None:
            self.reference = np.asarray(hold, dtype=np.float64).copy()
        self.velocity = np.zeros(len(self.joint_names))

    def update(self, now: float, dt: float) -> tuple[np.ndarray, np.ndarray]:
        """Advance the reference by one step of ``dt`` s ending at sim time ``now``; returns (position, velocity).

        Speed scaling (as UR's scaled_pos_joint_traj_controller): the trajectory's own clock advances by ``dt``
        unless that would move some joint faster than its limit; then it advances only as far as the limit allows,
        so all joints slow down together and the joint-space path keeps its shape. A residual jump (a start point
        away from the present reference) is closed at the velocity limit.
        """
        if self.spline is None:
            self.velocity = np.zeros_like(self.reference)
            return self.reference.copy(), self.velocity.copy()
        if self.clock_ is None:  # first update: the trajectory clock starts at the time since its start stamp
            self.clock_ = now - dt - self.start_time
        step = self.vmax * dt
        tau = self.clock_ + dt
        q_des, _ = self.spline.sample(tau)
        ratio = float(np.max(np.abs(q_des - self.reference) / step))
        for _ in range(8):  # shrink the time step until no joint exceeds its limit (exact on linear segments)
            if ratio <= 1.0 + 1e-9:
                break
            self.velocity_limited = True
            tau = self.clock_ + (tau - self.clock_) / ratio
            q_des, _ = self.spline.sample(tau)
            ratio = float(np.max(np.abs(q_des - self.reference) / step))
        self.clock_ = tau
        delta = np.clip(q_des - self.reference, -step, step)
        self.reference = self.reference + delta
        self.velocity = delta / dt
        if tau >= self.spline.duration and np.abs(self.reference - self.spline.goal).max() < 1e-9:
            self.reference = self.spline.goal.copy()
            self.spline = None
            self.velocity = np.zeros_like(self.reference)
        return self.reference.copy(), self.velocity.copy()
