"""Random clutter: N objects dropped one by one above the workspace and settled, reproducible from a seed.

The same seed gives the same scene (PyBullet DIRECT is deterministic for the same sequence of calls). One object,
the target, has the target colour; the others take the remaining palette colours.
"""

from __future__ import annotations

import zlib
from typing import TYPE_CHECKING

import numpy as np

from pg_sim.scenes.colors import COLORS, resolve_color
from pg_sim.scenes.scene import ObjectSpec, SceneSpec

if TYPE_CHECKING:  # a type only: scene sampling needs no simulator
    from pg_sim.world.world import World

TARGET_RETRIES = 8  # extra re-drops of a target still outside the workspace after the scene's own retries

BLOCKS = ("cube", "rect", "triangle", "arch", "cylinder", "half_cube", "half_cylinder")


def sample_drops(n: int, seed: int, target: str = "green", shapes: tuple[str, ...] = BLOCKS,
                 half_extent: float = 0.11, drop_height: float = 0.12) -> SceneSpec:
    """Drop poses (x, y uniform in +-half_extent m, z = drop_height, random orientation); object 0 is the target."""
    if n < 1:
        raise ValueError(f"a random scene needs at least one object, got {n}")
    rng = np.random.default_rng(seed)
    others = [name for name in COLORS if name != target]
    objects = []
    for i in range(n):
        xy = rng.uniform(-half_extent, half_extent, 2)
        rpy = rng.uniform(-np.pi, np.pi, 3)
        color = target if i == 0 else others[int(rng.integers(len(others)))]
        objects.append(ObjectSpec(
            shape=str(shapes[int(rng.integers(len(shapes)))]), size=None, color=resolve_color(color),
            pose=(float(xy[0]), float(xy[1]), drop_height, *(float(a) for a in rpy)), mesh=None,
            target=i == 0, name=f"obj{i}",
        ))
    order = rng.permutation(n)  # the target is not always dropped first (buried) or last (on top)
    return SceneSpec(name=f"random-{n}-seed{seed}", target=target, objects=tuple(objects[k] for k in order),
                     family="random")


def drop_scene(world: World, drops: SceneSpec, settle_each: float = 0.25, retries: int = 3) -> SceneSpec:
    """Spawn the drops one at a time into an emptied world, settle, re-drop escapees (`retries` times, then the
    target alone up to TARGET_RETRIES more: the protocol's reset needs it inside); returns the settled scene."""
    world.clear_objects()
    world.home()
    rng = np.random.default_rng(zlib.crc32(drops.name.encode()))
    for spec in drops.objects:
        world.add_object(spec)
        steps = int(settle_each / world.time_step)
        for _ in range(steps):
            world.step()
    world.scene = drops
    world.settle()
    ws = world.geometry.workspace
    for attempt in range(retries + TARGET_RETRIES):  # after `retries`, the target only: other escapees may stay out
        out = [b for b, pose in world.object_poses().items()
               if not (ws.x[0] + 0.01 < pose[0] < ws.x[1] - 0.01 and ws.y[0] + 0.01 < pose[1] < ws.y[1] - 0.01)
               and (attempt < retries or b == world.target_id)]
        if not out:
            break
        for body in out:
            spec = world.objects[body]
            world.remove_object(body)
            xy = rng.uniform(-0.05, 0.05, 2)
            world.add_object(_moved(spec, (float(xy[0]), float(xy[1]), 0.15)))
        world.settle()
    return world.snapshot(drops.name)


def _moved(spec: ObjectSpec, xyz: tuple[float, float, float]) -> ObjectSpec:
    from dataclasses import replace

    return replace(spec, pose=(*xyz, *spec.pose[3:]))
