"""Which objects of a simulated world still move, and freezing those that fell off the table for good (the sim
runtime's busy test and its guard against objects falling forever; pg_sim.runtime.sim_runtime). `frozen` holds the
body ids made static so far; velocities in m/s and rad/s, heights in `world` metres."""

from __future__ import annotations

import numpy as np
import pybullet as p

from pg_sim.world.world import World

FALLEN_Z = -0.5          # m: objects below this have left the table for good and are frozen
OBJECT_LIN_TOL = 0.01    # m/s: an object moving faster than this keeps the sim busy
OBJECT_ANG_TOL = 0.1     # rad/s


def objects_moving(world: World, frozen: set[int]) -> bool:
    """Whether an object of `world` not in `frozen` moves faster than OBJECT_LIN_TOL or turns faster than
    OBJECT_ANG_TOL."""
    c = world.client
    for body in world.objects:
        if body in frozen:
            continue
        lin, ang = p.getBaseVelocity(body, physicsClientId=c)
        if np.dot(lin, lin) > OBJECT_LIN_TOL ** 2 or np.dot(ang, ang) > OBJECT_ANG_TOL ** 2:
            return True
    return False


def freeze_fallen(world: World, frozen: set[int]) -> None:
    """Make static, where they are, the objects of `world` below FALLEN_Z, adding them to `frozen`."""
    c = world.client
    for body in world.objects:
        if body in frozen:
            continue
        pos, _ = p.getBasePositionAndOrientation(body, physicsClientId=c)
        if pos[2] < FALLEN_Z:
            p.resetBaseVelocity(body, [0.0, 0.0, 0.0], [0.0, 0.0, 0.0], physicsClientId=c)
            p.changeDynamics(body, -1, mass=0.0, physicsClientId=c)  # static from now on
            frozen.add(body)
