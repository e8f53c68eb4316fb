"""The fake dual arm of rt_primitive_controller (the rostest fixture of the code around it, allowed as such): both
UR5e arms and grippers that follow commanded JointTrajectory messages by linear interpolation in ROS time from their
receipt, move the fingers at the gripper's speed (stopping at `object_width` when closing on a simulated object),
publish /joint_states at 100 Hz unless paused, and record what they received."""

from __future__ import annotations

import math
import threading

import numpy as np
import rospy
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64
from trajectory_msgs.msg import JointTrajectory

from pg_core.geometry import load

ARMS = ("left", "right")
ARM_JOINTS = ("shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint", "wrist_1_joint", "wrist_2_joint",
              "wrist_3_joint")
GEOMETRY = load()


class FakeArms:
    """Both arms and grippers: follows commands in ROS time, publishes /joint_states, records what it received."""

    def __init__(self) -> None:
        self.lock = threading.Lock()
        self.q = {arm: np.array(GEOMETRY.robot.arms[arm].home, dtype=float) for arm in ARMS}
        self.opening = {arm: GEOMETRY.gripper.max_opening for arm in ARMS}
        self.gripper_target = dict(self.opening)
        self.active: dict[str, tuple[float, np.ndarray, np.ndarray]] = {}  # arm -> (t0, times, positions)
        self.trajectories: list[tuple[str, JointTrajectory]] = []
        self.gripper_commands: list[tuple[str, float]] = []
        self.object_width: float | None = None  # closing stops here when set
        self.paused = False
        self.slowdown = 1.0  # trajectories are followed this many times slower (inf: a stuck arm)
        self.pub = rospy.Publisher("/joint_states", JointState, queue_size=10)
        self.subs = []
        for arm in ARMS:
            self.subs.append(rospy.Subscriber(f"/{arm}/scaled_pos_joint_traj_controller/command", JointTrajectory,
                                              self._on_trajectory, callback_args=arm, queue_size=10))
            self.subs.append(rospy.Subscriber(f"/{arm}/gripper/command", Float64, self._on_gripper,
                                              callback_args=arm, queue_size=10))
        self.last = rospy.get_time()
        self.timer = rospy.Timer(rospy.Duration(0.01), self._tick)

    def _on_trajectory(self, msg: JointTrajectory, arm: str) -> None:
        times = np.array([p.time_from_start.to_sec() for p in msg.points])
        positions = np.array([p.positions for p in msg.points])
        order = [msg.joint_names.index(f"{arm}_{j}") for j in ARM_JOINTS]
        with self.lock:
            self.trajectories.append((arm, msg))
            self.active[arm] = (rospy.get_time(), times, positions[:, order])

    def _on_gripper(self, msg: Float64, arm: str) -> None:
        with self.lock:
            self.gripper_commands.append((arm, msg.data))
            self.gripper_target[arm] = msg.data

    def _tick(self, _event) -> None:
        now = rospy.get_time()
        with self.lock:
            dt, self.last = now - self.last, now
            for arm in ARMS:
                if arm in self.active:
                    t0, times, positions = self.active[arm]
                    t = (now - t0) / self.slowdown
                    self.q[arm] = np.array([np.interp(t, times, positions[:, j]) for j in range(6)])
                    if t >= times[-1]:
                        del self.active[arm]
                target = self.gripper_target[arm]
                if self.object_width is not None and target < self.object_width:
                    target = self.object_width
                step = 2 * GEOMETRY.gripper.finger_speed * dt
                self.opening[arm] += float(np.clip(target - self.opening[arm], -step, step))
            if self.paused:
                return
            msg = JointState()
            msg.header.stamp = rospy.Time.now()
            for arm in ARMS:
                msg.name += [f"{arm}_{j}" for j in ARM_JOINTS]
                msg.position += list(self.q[arm])
                msg.name += [f"{arm}_gripper_finger1_joint", f"{arm}_gripper_finger2_joint"]
                msg.position += [self.opening[arm] / 2, self.opening[arm] / 2]
        try:
            self.pub.publish(msg)
        except rospy.ROSException:  # shutting down
            pass

    def set_slowdown(self, factor: float) -> None:
        with self.lock:
            self.slowdown = factor
            if math.isinf(factor):
                self.active.clear()  # a stuck arm drops what it was given

    def received(self) -> tuple[int, int]:
        with self.lock:
            return len(self.trajectories), len(self.gripper_commands)
