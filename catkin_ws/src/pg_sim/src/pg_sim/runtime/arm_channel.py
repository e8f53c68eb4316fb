"""One arm as the sim runtime drives it (pg_sim.runtime.sim_runtime): names, trajectory follower, gripper target."""

from __future__ import annotations

import numpy as np

from pg_core.geometry import Geometry
from pg_sim.robot.trajectory import TrajectoryFollower
from pg_sim.world.world import World


class ArmChannel:
    """What the runtime tracks of one arm: its driver, its joint and finger names (`<arm>_<joint>`), the trajectory
    being followed, its settling and the gripper command."""

    def __init__(self, name: str, world: World, geo: Geometry) -> None:
        self.name = name
        self.driver = world.arms[name]
        self.joint_names = tuple(f"{name}_{j}" for j in geo.robot.joint_names)
        self.finger_names = (f"{name}_gripper_finger1_joint", f"{name}_gripper_finger2_joint")
        self.follower = TrajectoryFollower(self.joint_names, np.asarray(geo.robot.arms[name].home),
                                           geo.robot.joint_velocity_limit, geo.robot.joint_lower,
                                           geo.robot.joint_upper, prefix=f"{name}_")
        self.settle_until = -1.0
        self.tracking = False  # a trajectory was given and its settling has not started yet
        self.gripper_target = geo.gripper.max_opening
        self.gripper_time = -np.inf

    def home(self, q: np.ndarray, opening: float) -> None:
        self.follower.stop(hold=q)
        self.settle_until = -1.0
        self.tracking = False
        self.gripper_target = opening
        self.gripper_time = -np.inf
