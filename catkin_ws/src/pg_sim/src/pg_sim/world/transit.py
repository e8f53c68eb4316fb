"""Kinematic free-space transit of one arm (the fast simulation mode, pg_sim.world.sim_mode).

A joint-space move through free space (home to above a pre-pose, back home) changes nothing in the scene while
the arm keeps away from every object; stepping physics through it only costs time. `teleport` samples the
straight joint-space path (at most `mode.transit_step` rad apart), and at every sample checks that every link of
the moving arm (its gripper included, fingers at their commanded opening) keeps `mode.transit_clearance` m from
every object: broadphase AABB overlap first, exact closest points for the overlapping pairs. When the whole path
is clear, the arm (and its fingers) is placed at the end and held there; otherwise nothing moves and the caller
simulates the move. The objects then get physics until they are at rest, at most as long as the move would have
taken (`World.settle`), so what was still moving keeps moving as it would have.

Angles in rad, distances in m, times in simulated s.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import pybullet as p

from pg_sim.robot.arm_driver import ArmDriver
from pg_sim.world.sim_mode import SimMode
from pg_sim.world.world import World


def arm_links(world: World, arm: str) -> tuple[int, ...]:
    """Every link of `arm` (its UR links and its gripper): the links whose names start with "<arm>_"."""
    body, client = world.robot.body, world.client
    prefix = f"{arm}_"
    return tuple(j for j in range(p.getNumJoints(body, physicsClientId=client))
                 if p.getJointInfo(body, j, physicsClientId=client)[12].decode().startswith(prefix))


def samples(path: Sequence[np.ndarray], max_step: float) -> list[np.ndarray]:
    """The joint configurations along the straight segments of `path`, at most `max_step` rad apart, ends
    included."""
    qs = [np.asarray(q, dtype=np.float64) for q in path]
    out = [qs[0]]
    for a, b in zip(qs[:-1], qs[1:], strict=True):
        n = max(1, int(np.ceil(np.abs(b - a).max() / max_step)))
        out.extend(a + (b - a) * (i / n) for i in range(1, n + 1))
    return out


def clear_of_objects(world: World, links: Sequence[int], clearance: float) -> bool:
    """Whether every link in `links` of the robot, where it is now, keeps `clearance` (m) from every object."""
    body, client = world.robot.body, world.client
    for link in links:
        lo, hi = p.getAABB(body, link, physicsClientId=client)
        near = p.getOverlappingObjects(np.subtract(lo, clearance), np.add(hi, clearance), physicsClientId=client)
        for other, _ in near or ():
            if other in world.objects and p.getClosestPoints(body, other, clearance, linkIndexA=link,
                                                             physicsClientId=client):
                return False
    return True


def holds_object(world: World, driver: ArmDriver) -> bool:
    """Whether a finger of the arm touches an object (a held object must travel under physics)."""
    return any(c[2] in world.objects
               for finger in driver.arm.fingers
               for c in p.getContactPoints(bodyA=world.robot.body, linkIndexA=finger, physicsClientId=world.client))


def teleport(world: World, driver: ArmDriver, path: Sequence[np.ndarray], links: Sequence[int], mode: SimMode,
             opening: float) -> bool:
    """Place the arm at the end of `path` (first point: where it is) with its fingers at `opening` (m) when the
    whole path keeps `mode.transit_clearance` from every object and the fingers hold nothing; True when it
    moved, False (arm and fingers as they were) otherwise. Steps no physics."""
    if holds_object(world, driver):
        return False
    start_q, start_fingers = driver.joints(), driver.finger_positions()
    driver.place(start_q, opening)
    for q in samples(path, mode.transit_step):
        driver.place(q, opening)
        if not clear_of_objects(world, links, mode.transit_clearance):
            driver.place(start_q, None, start_fingers)
            return False
    driver.reset(path[-1], opening)  # placed, and the motors hold it there
    return True


def transit(world: World, driver: ArmDriver, path: Sequence[np.ndarray], links: Sequence[int], mode: SimMode,
            opening: float, settle_time: float) -> bool:
    """The fast mode's free-space move: a teleport when clear, then physics until the objects are at rest, at
    most `settle_time` s (the simulated move's duration). False when not clear: nothing moved, the caller
    simulates the move."""
    if not teleport(world, driver, path, links, mode, opening):
        return False
    world.settle(max_time=settle_time, min_time=0.0)
    return True
