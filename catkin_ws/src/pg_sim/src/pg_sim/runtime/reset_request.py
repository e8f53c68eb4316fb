"""A scene reset request of the sim node (pg_msgs/ResetScene) resolved into a scene, checked before anything
changes: a shipped name or YAML file, or a generated family (random, novel, mixed, ...) of N objects from a seed."""

from __future__ import annotations

import pybullet as p

from pg_sim.runtime.runtime_types import ResetRequest
from pg_sim.scenes.objects import build_shape
from pg_sim.scenes.scene import SceneError, SceneSpec, find_scene, load_scene
from pg_sim.world.scene_families import FAMILIES, MAX_OBJECTS, parse_generated, sample_family

MAX_RANDOM_OBJECTS = MAX_OBJECTS  # largest generated scene a reset accepts


def resolve_reset(req: ResetRequest) -> tuple[SceneSpec, bool]:
    """The scene of a request and whether it is a generated drop (``random``, ``novel``, ... with num_objects, or
    ``<family>-N``); raises SceneError/ValueError before any change."""
    text = (req.scene or "").strip()
    if not text:
        raise SceneError("empty scene: give a shipped scene name (e.g. packed/case01), a YAML file or 'random'")
    parsed = parse_generated(text)
    if text in FAMILIES or parsed:
        family, n = parsed if parsed else (text, int(req.num_objects))
        if parsed and req.num_objects and int(req.num_objects) != n:
            raise SceneError(f"scene {text!r} names {n} objects but num_objects is {req.num_objects}")
        if not 1 <= n <= MAX_RANDOM_OBJECTS:
            raise SceneError(f"a {family} scene needs num_objects in [1, {MAX_RANDOM_OBJECTS}], got {n}")
        scene, random = sample_family(f"{family}-{n}", int(req.seed)), True
    else:
        scene, random = load_scene(find_scene(text)), False
    check_buildable(scene)
    return scene, random


def check_buildable(scene: SceneSpec) -> None:
    """Build every object's shapes in a scratch PyBullet client; raises ValueError naming the first that fails."""
    client = p.connect(p.DIRECT)
    try:
        for spec in scene.objects:
            try:
                build_shape(client, spec)
            except (ValueError, OSError, RuntimeError, p.error) as e:
                raise SceneError(f"scene {scene.name!r}: object {spec.name!r} ({spec.shape}) cannot be built: {e}") \
                    from None
    finally:
        p.disconnect(client)
