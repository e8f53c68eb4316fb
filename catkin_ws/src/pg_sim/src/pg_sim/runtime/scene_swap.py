"""Replacing the sim node's objects by a checked scene, answering success only for a scene at rest with its target in
the workspace; on any failure the previous objects are put back (at their poses before the swap).

A generated scene is dropped (pg_sim.world.random_scene.drop_scene), a scene file loaded and settled
(World.load_scene). Objects still moving afterwards are damped to rest (pg_sim.world.rest.bring_to_rest, at most
``rest_timeout`` s of sim time). A scene at rest is then watched, undamped, for WATCH_WINDOW s, 2 s (pg_sim.world
.rest.watch_still; Bullet puts objects that stay still that long to sleep): it is accepted only when no object
moved more than the still tolerances (1 mm, 0.01 rad) meanwhile;
otherwise the objects that moved are damped until they have stayed still (and others that move faster than the
rest tolerances with them) and the scene is watched anew, for at most WATCH_TIMEOUT s of sim
time in all. Refused, previous scene restored, message naming the object: an object that does not come to rest or
keeps creeping, a target that comes to rest outside the workspace box (pg_core.geometry.Workspace).
"""

from __future__ import annotations

import numpy as np
import pybullet as p

from pg_core.user_text import cut
from pg_sim.runtime.runtime_types import ResetResult
from pg_sim.scenes.scene import SceneSpec
from pg_sim.world.random_scene import drop_scene
from pg_sim.world.rest import (
    STILL_ANG_TOL,
    STILL_POS_TOL,
    WATCH_TIMEOUT,
    WATCH_WINDOW,
    bring_to_rest,
    watch_still,
)
from pg_sim.world.world import World

NAMES_LISTED = 6  # object names a message lists; the others are counted


class SwapFailed(Exception):
    """The new scene is not usable (message says why); the caller's scene is restored."""


def swap_scene(world: World, scene: SceneSpec, generated: bool, rest_timeout: float) -> ResetResult:
    """Load ``scene`` into ``world`` (``generated``: drop it from its drop poses) and bring it to rest; returns the
    result (unsuccessful: the previous objects are back). Arms are left to the caller (they are homed by loading)."""
    previous = world.snapshot() if world.scene is not None else None
    try:
        if generated:
            drop_scene(world, scene)
        else:
            world.load_scene(scene)
        _check_at_rest(world, rest_timeout)
        _check_target_inside(world)
    except Exception as e:  # noqa: BLE001 - whatever failed, the previous objects come back and the caller hears why
        world.clear_objects()
        if previous is not None:
            world.load_scene(previous, settle=False)
        why = str(e) or type(e).__name__
        return ResetResult(False, f"reset failed while loading {cut(scene.name, quoted=True)}, previous scene "
                                  f"restored: {why}")
    loaded = world.scene
    assert loaded is not None
    return ResetResult(True, f"loaded {cut(loaded.name)} ({len(world.objects)} objects, target {loaded.target})",
                       loaded.name, loaded.target, len(world.objects))


def _check_at_rest(world: World, rest_timeout: float, window: float = WATCH_WINDOW,
                   watch_timeout: float = WATCH_TIMEOUT) -> None:
    """Bring the scene to rest, then require ``window`` s without motion (module docstring); raises SwapFailed."""
    report = bring_to_rest(world, rest_timeout)
    if not report.at_rest:
        raise SwapFailed(f"object(s) {_names(report.moving)} still moving after {report.time:.1f} s of "
                         f"damping (rest_timeout {rest_timeout:g} s)")
    if window <= 0.0:
        return
    deadline = world.sim_time + watch_timeout
    while True:
        moved = watch_still(world, window)
        if not moved:
            return
        left = deadline - world.sim_time
        if left < window:
            names = [world.objects[b].name for b in moved]
            raise SwapFailed(f"object(s) {_names(names)} still moving (creeping) after {watch_timeout:g} s of "
                             f"watching: more than {STILL_POS_TOL * 1000:g} mm or {STILL_ANG_TOL:g} rad in "
                             f"{window:g} s")
        report = bring_to_rest(world, left - window, also=moved)
        if not report.at_rest:
            raise SwapFailed(f"object(s) {_names(report.moving)} still moving after {report.time:.1f} s of "
                             f"damping while watched")


def _check_target_inside(world: World) -> None:
    target = world.target_id
    if target is None:
        return
    pos, _ = p.getBasePositionAndOrientation(target, physicsClientId=world.client)
    if not world.geometry.workspace.contains(np.asarray(pos)):
        spec = world.objects[target]
        xyz = ", ".join(f"{v:.3f}" for v in pos)
        raise SwapFailed(f"target {cut(spec.name, quoted=True)} ({spec.shape}) came to rest outside the workspace "
                         f"at ({xyz}) m")


def _names(names: list[str]) -> str:
    """The first NAMES_LISTED names, each quoted and cut (pg_core.user_text.cut), and how many more there are."""
    shown = ", ".join(cut(n, quoted=True) for n in names[:NAMES_LISTED])
    more = len(names) - NAMES_LISTED
    return shown + (f" and {more} more" if more > 0 else "")
