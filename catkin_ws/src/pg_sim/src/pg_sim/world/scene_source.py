"""Resolve a scene argument (shipped name, YAML path, or `random-N`) into a settled World."""

from __future__ import annotations

import re

from pg_sim.scenes.scene import find_scene, load_scene
from pg_sim.world.random_scene import drop_scene, sample_drops
from pg_sim.world.world import World

RANDOM = re.compile(r"^random-(\d+)$")
# scenes generated from a seed: random-N (dropped over +-0.11 m) and dense-N (over +-0.05 m, training clutter)
GENERATED = re.compile(r"^(random|dense)-(\d+)$")


def make_world_with_scene(source: str, seed: int = 0, gui: bool = False) -> World:
    """A World holding the settled scene; raises SceneError/ValueError for unknown names or bad files."""

    match = RANDOM.match(source)
    scene = None if match else load_scene(find_scene(source))  # validate before starting physics
    world = World(gui=gui)
    try:
        if match:
            drop_scene(world, sample_drops(int(match.group(1)), seed))
        else:
            world.load_scene(scene)
    except Exception:
        world.close()
        raise
    return world
