"""A scene reset request of the sim node (pg_msgs/ResetScene) resolved into a scene, checked before anything
changes: a shipped name or YAML file, or a generated family (random, novel, mixed, ...) of N objects from a seed.

Every refusal is a SceneError whose message starts with the request field it is about (``scene``, ``num_objects``,
``seed``) and shows the offending value cut (pg_core.user_text.cut).
"""

from __future__ import annotations

import pybullet as p

from pg_core.user_text import cut
from pg_sim.runtime.runtime_types import ResetRequest
from pg_sim.scenes.objects import build_shape
from pg_sim.scenes.scene import SceneError, SceneSpec, find_scene, load_scene
from pg_sim.scenes.scene_folders import AllowedFolders
from pg_sim.scenes.scene_limits import DEFAULT_LIMITS, SceneLimits
from pg_sim.world.scene_families import FAMILIES, MAX_OBJECTS, parse_generated, sample_family
from pg_sim.world.world import ShapeKey, shape_key

MAX_RANDOM_OBJECTS = MAX_OBJECTS  # largest generated scene a reset accepts
MAX_SCENE_TEXT = 1024  # characters: longest scene name or path a reset accepts
BUILT_KEYS_KEPT = 4096  # shape keys remembered as buildable (then forgotten all at once and re-checked)
_built: set[ShapeKey] = set()  # shape keys (pg_sim.world.world.shape_key) that built in a scratch client


def resolve_reset(req: ResetRequest, limits: SceneLimits = DEFAULT_LIMITS,
                  folders: AllowedFolders | None = None) -> tuple[SceneSpec, bool]:
    """The scene of a request and whether it is a generated drop (``random``, ``novel``, ... with num_objects, or
    ``<family>-N``); raises SceneError before any change. Scene files are held to ``limits``; with ``folders`` (a
    request from another process) scene and mesh files must lie in them, else any path is read."""
    text = (req.scene or "").strip()
    if not text:
        raise SceneError("scene: empty scene name: give a shipped scene name (e.g. packed/case01), a YAML file or "
                         "'random'")
    if len(text) > MAX_SCENE_TEXT:
        raise SceneError(f"scene: {len(text)} characters, at most {MAX_SCENE_TEXT}: {cut(text, quoted=True)}")
    seed, count = int(req.seed), int(req.num_objects)
    if seed < 0:
        raise SceneError(f"seed: must be a non-negative integer, got {seed}")
    if count < 0:
        raise SceneError(f"num_objects: must be a non-negative integer, got {count}")
    parsed = parse_generated(text)
    if text in FAMILIES or parsed:
        family, n = parsed if parsed else (text, count)
        if parsed and count and count != n:
            raise SceneError(f"num_objects: scene {cut(text, quoted=True)} names {n} objects but num_objects is "
                             f"{count}")
        most = min(MAX_RANDOM_OBJECTS, limits.max_objects)
        if not 1 <= n <= most:
            raise SceneError(f"num_objects: a {family} scene needs num_objects in [1, {most}], got {n}")
        scene, generated = sample_family(f"{family}-{n}", seed), True
    else:
        try:
            path = folders.find_scene(text) if folders is not None else find_scene(text)  # messages: "scene ..."
        except OSError as e:  # e.g. a name too long for the file system
            raise SceneError(f"scene {cut(text, quoted=True)}: {e.strerror}") from None
        try:
            scene = load_scene(path, limits, folders.meshes if folders is not None else None)
        except SceneError as e:
            raise SceneError(f"scene: {e}") from None
        generated = False
    check_buildable(scene)
    return scene, generated


def check_buildable(scene: SceneSpec) -> None:
    """Build the shapes of every object whose shape key has not built before in a scratch PyBullet client (none
    when all have: a client's shapes are freed only in part when it disconnects); raises SceneError naming the
    first that fails."""
    todo = [(spec, key) for spec in scene.objects if (key := shape_key(spec)) not in _built]
    if not todo:
        return
    client = p.connect(p.DIRECT)
    try:
        for spec, key in todo:
            if key in _built:  # an earlier object of this scene had it
                continue
            try:
                build_shape(client, spec)
            except (ValueError, OSError, RuntimeError, p.error) as e:
                raise SceneError(f"scene {cut(scene.name, quoted=True)}: object {cut(spec.name, quoted=True)} "
                                 f"({spec.shape}) cannot be built: {e}") from None
            if len(_built) >= BUILT_KEYS_KEPT:
                _built.clear()
            _built.add(key)
    finally:
        p.disconnect(client)
