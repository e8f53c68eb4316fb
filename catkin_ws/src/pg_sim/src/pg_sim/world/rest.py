"""Bringing a loaded scene to rest: objects still moving after `World.settle` are damped until they stop.

`World.settle` gives up after its ``max_time`` (3 s of sim time) whether or not everything has stopped: a cylinder
dropped on its side keeps rolling across the table (rolling friction is small) and a half-cylinder may rock for
seconds. `bring_to_rest` is for callers that promise a scene at rest (the sim node's reset). When every object is
already at rest it steps nothing, so such scenes stay bit-identical. Otherwise every object seen moving gets a strong
linear and angular damping while the world steps on, until all objects are at rest or ``timeout`` s of sim time
have passed; the damped objects then get their spawn damping (pg_sim.scenes.objects.OBJECT_DAMPING) back.

An object is at rest when its velocity is below REST_LIN_TOL and REST_ANG_TOL, or when it has stayed within
STILL_POS_TOL and STILL_ANG_TOL of its pose for STILL_WINDOW s: a block wedged in a pile can jitter in place at
measurable velocities (contact-solver noise, a fraction of a millimetre) without going anywhere.

An object can also pass both tests while it is not at rest: balanced on an edge and tipping over slowly, or
creeping down a neighbour, it moves a millimetre in half a second and then falls. `watch_still` steps the world
undamped for a window and names the objects that moved more than the still tolerances meanwhile; a caller that
promises a scene at rest (pg_sim.runtime.scene_swap) accepts a scene only after such a window without motion.
The window, WATCH_WINDOW, is 2 s: Bullet's deactivation time. A body whose velocity stays below Bullet's sleeping
thresholds that long is put to sleep with its contact island and moves no more until something touches it (an arm,
a falling object), so a scene that stayed still through the window stays still afterwards. A 1 s window let a
slow creeper through: a rect on a half-cylinder crept 0.1 mm in the window, then slipped 5.35 mm 0.6 s later.

Evaluation and training (World.load_scene, pg_sim.world.scene_families.generate_scene) do not call it: their scenes
are the ones their records were made with.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import pybullet as p

from pg_sim.scenes.objects import OBJECT_DAMPING
from pg_sim.world.world import World

REST_LIN_TOL = 2e-3   # m/s: an object slower than this (and REST_ANG_TOL) is at rest, as in World.settle
REST_ANG_TOL = 2e-2   # rad/s
REST_TIMEOUT = 3.0    # s of sim time that damped objects get to stop
REST_DAMPING = 10.0   # 1/s: linear and angular damping of a damped object (velocity halves in about 0.07 s)
STILL_WINDOW = 0.5    # s: an object whose pose stays within the tolerances below this long is at rest ...
STILL_POS_TOL = 1e-3  # m
STILL_ANG_TOL = 1e-2  # rad
_CHECK_EVERY = 12     # steps between checks (20 Hz of sim time), as World.settle
WATCH_WINDOW = 2.0    # s of sim time a scene at rest must stay within the still tolerances before it is accepted
#                       (Bullet's deactivation time: objects still that long sleep)
WATCH_TIMEOUT = 6.0   # s of sim time spent watching (and re-settling) at most, after REST_TIMEOUT: room for a
#                       window, damping and a second window


@dataclass(frozen=True)
class RestReport:
    """What `bring_to_rest` did: sim time stepped (s), the objects it damped and those still moving at the end
    (names; empty when the scene is at rest)."""

    time: float
    damped: tuple[str, ...]
    moving: tuple[str, ...]

    @property
    def at_rest(self) -> bool:
        return not self.moving


def moving_objects(world: World, lin_tol: float = REST_LIN_TOL, ang_tol: float = REST_ANG_TOL) -> list[int]:
    """Body ids of the world's objects moving faster than ``lin_tol`` m/s or ``ang_tol`` rad/s."""
    out = []
    for body in world.objects:
        lin, ang = p.getBaseVelocity(body, physicsClientId=world.client)
        if float(np.linalg.norm(lin)) >= lin_tol or float(np.linalg.norm(ang)) >= ang_tol:
            out.append(body)
    return out


def bring_to_rest(world: World, timeout: float = REST_TIMEOUT, damping: float = REST_DAMPING,
                  lin_tol: float = REST_LIN_TOL, ang_tol: float = REST_ANG_TOL,
                  also: Sequence[int] = ()) -> RestReport:
    """Damp moving objects until every object is at rest or ``timeout`` s of sim time pass (module docstring).
    ``also``: objects (body ids) damped as well, however slowly they move, until they have stayed still for
    STILL_WINDOW s (objects that `watch_still` saw creeping)."""
    forced = [b for b in also if b in world.objects]
    moving = list(dict.fromkeys([*moving_objects(world, lin_tol, ang_tol), *forced]))
    t0 = world.sim_time
    damped: list[int] = []
    poses: dict[int, list[tuple[float, np.ndarray, np.ndarray]]] = {}  # body -> [(sim time, position, quaternion)]
    try:
        while moving and world.sim_time - t0 < timeout:
            for body in moving:
                if body not in damped:
                    p.changeDynamics(body, -1, linearDamping=damping, angularDamping=damping,
                                     physicsClientId=world.client)
                    damped.append(body)
            for _ in range(_CHECK_EVERY):
                world.step()
            for body in damped:
                pos, quat = p.getBasePositionAndOrientation(body, physicsClientId=world.client)
                poses.setdefault(body, []).append((world.sim_time, np.asarray(pos), np.asarray(quat)))
            fast = moving_objects(world, lin_tol, ang_tol)
            moving = [b for b in dict.fromkeys([*fast, *forced]) if not stayed_still(poses.get(b, []))]
    finally:
        for body in damped:
            p.changeDynamics(body, -1, linearDamping=OBJECT_DAMPING, angularDamping=OBJECT_DAMPING,
                             physicsClientId=world.client)
    names = world.objects
    return RestReport(world.sim_time - t0, tuple(names[b].name for b in damped), tuple(names[b].name for b in moving))


def stayed_still(history: list[tuple[float, np.ndarray, np.ndarray]]) -> bool:
    """True when the samples of the last STILL_WINDOW s (which must span it) stay within the still tolerances of the
    newest pose."""
    if not history or history[-1][0] - history[0][0] < STILL_WINDOW - 1e-9:
        return False
    t, pos, quat = history[-1]
    for ts, ps, qs in reversed(history):
        if t - ts > STILL_WINDOW + 1e-9:
            break
        angle = 2.0 * np.arccos(min(1.0, abs(float(np.dot(quat, qs)))))
        if float(np.linalg.norm(pos - ps)) > STILL_POS_TOL or angle > STILL_ANG_TOL:
            return False
    return True


def watch_still(world: World, window: float = WATCH_WINDOW, pos_tol: float = STILL_POS_TOL,
                ang_tol: float = STILL_ANG_TOL) -> list[int]:
    """Step the world ``window`` s of sim time, nothing damped; returns the objects (body ids) whose pose moved more
    than ``pos_tol`` m or ``ang_tol`` rad from where it was at the start, checked every _CHECK_EVERY steps. Stops
    early once every object has moved."""
    start = {b: _pose(world, b) for b in world.objects}
    moved: list[int] = []
    end = world.sim_time + window - 1e-9
    while world.sim_time < end and len(moved) < len(start):
        for _ in range(_CHECK_EVERY):
            world.step()
        for body, (pos0, quat0) in start.items():
            if body in moved:
                continue
            pos, quat = _pose(world, body)
            angle = 2.0 * np.arccos(min(1.0, abs(float(np.dot(quat, quat0)))))
            if float(np.linalg.norm(pos - pos0)) > pos_tol or angle > ang_tol:
                moved.append(body)
    return moved


def _pose(world: World, body: int) -> tuple[np.ndarray, np.ndarray]:
    pos, quat = p.getBasePositionAndOrientation(body, physicsClientId=world.client)
    return np.asarray(pos), np.asarray(quat)
