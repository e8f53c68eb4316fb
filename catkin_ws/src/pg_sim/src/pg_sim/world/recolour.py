"""Scene colour variants: the objects of a built scene painted again so that colours repeat, and a colour no longer
names a single object (evaluation of targets named by a point or a mask).

Modes (COLOUR_MODES):
- ``unique``: the scene as built (the target's colour is its own; nothing is painted);
- ``repeated``: every object gets a palette colour (pg_core.palette.COLORS) drawn uniformly with replacement, then
  one other object, drawn too, takes the target's colour: at least two objects share the target's colour;
- ``same``: every object gets one palette colour, drawn.

The draws come from the trial seed alone (`draw_colours`: a generator of its own stream, so the scene's own draws
are untouched), in the world's object order (spawn order): the same scene and seed give the same colours.
`recolour` paints the bodies (PyBullet ``changeVisualShape``) and keeps the world's records true: the object specs
(`World.objects`, body id -> ObjectSpec with the new RGB) and the scene (`World.scene`: its objects by name and its
target colour name). The target stays the same body (`World.target_id`); ground truth is by body id.
"""

from __future__ import annotations

from dataclasses import replace
from typing import TYPE_CHECKING

import numpy as np

from pg_sim.scenes.colors import COLORS, rgba

if TYPE_CHECKING:  # a type only
    from pg_sim.world.world import World

UNIQUE, REPEATED, SAME = "unique", "repeated", "same"
COLOUR_MODES = (UNIQUE, REPEATED, SAME)
RECOLOUR_STREAM = 0x5C0105  # second word of the generator's seed: its draws are apart from the scene's


def check_mode(mode: str) -> str:
    """`mode` when it is one of COLOUR_MODES; ValueError listing them otherwise."""
    if mode not in COLOUR_MODES:
        raise ValueError(f"unknown colour mode {mode!r}; known: {', '.join(COLOUR_MODES)}")
    return mode


def draw_colours(n: int, target: int, mode: str, seed: int) -> list[str] | None:
    """Palette names (COLORS) of `n` objects in order, the object at index `target` being the target, for `mode`
    and trial `seed` (module docstring); None for ``unique`` (nothing to paint). ValueError for an unknown mode, a
    target index outside 0..n-1, or ``repeated`` with fewer than 2 objects (no other object to share the colour)."""
    check_mode(mode)
    if mode == UNIQUE:
        return None
    if not 0 <= target < n:
        raise ValueError(f"target index {target} outside the {n} objects")
    names = list(COLORS)
    rng = np.random.default_rng([int(seed), RECOLOUR_STREAM])
    if mode == SAME:
        return [names[int(rng.integers(len(names)))]] * n
    if n < 2:
        raise ValueError(f"colours {REPEATED!r} needs at least 2 objects to repeat the target's colour, got {n}")
    colours = [names[int(k)] for k in rng.integers(len(names), size=n)]
    others = [i for i in range(n) if i != target]
    colours[others[int(rng.integers(len(others)))]] = colours[target]
    return colours


def recolour(world: World, mode: str, seed: int) -> dict[int, str]:
    """Paint the objects of `world` for `mode` and trial `seed` (module docstring); returns body id -> palette name
    of every painted object ({} for ``unique``). ValueError as draw_colours, or when the world holds no target."""
    import pybullet as p  # here: the mode names and draws serve processes without the simulator

    bodies = list(world.objects)
    if world.target_id is None or world.target_id not in world.objects:
        if mode == UNIQUE:
            return {}
        raise ValueError("recolour: the world holds no target object")
    colours = draw_colours(len(bodies), bodies.index(world.target_id), mode, seed)
    if colours is None:
        return {}
    painted = dict(zip(bodies, colours, strict=True))
    by_name: dict[str, tuple[int, int, int]] = {}
    for body, name in painted.items():
        rgb = COLORS[name]
        p.changeVisualShape(body, -1, rgbaColor=rgba(rgb), physicsClientId=world.client)
        spec = replace(world.objects[body], color=rgb)
        world.objects[body] = spec
        by_name[spec.name] = rgb
    if world.scene is not None:
        objects = tuple(replace(o, color=by_name.get(o.name, o.color)) for o in world.scene.objects)
        world.scene = replace(world.scene, target=painted[world.target_id], objects=objects)
    return painted

