"""Resolve a scene argument (shipped name, YAML path, or a generated `<family>-N`) into a settled World."""

from __future__ import annotations

from pg_sim.scenes.scene import find_scene, load_scene
from pg_sim.world.scene_families import GENERATED, generate_scene, parse_generated
from pg_sim.world.world import World

__all__ = ["GENERATED", "make_world_with_scene"]


def make_world_with_scene(source: str, seed: int = 0, gui: bool = False) -> World:
    """A World holding the settled scene; raises SceneError/ValueError for unknown names or bad files."""

    generated = parse_generated(source)
    scene = None if generated else load_scene(find_scene(source))  # validate before starting physics
    world = World(gui=gui)
    try:
        if generated:
            generate_scene(world, source, seed)
        else:
            world.load_scene(scene)
    except Exception:
        world.close()
        raise
    return world
