"""Ground-truth grasps of low catalogue objects: thin flat things (3-12 mm), pens lying down, small parts.

Each object lies alone on the table; the jaw comes down at its centre with the grasp z of pg_core.action_geometry
at that heightmap cell, closing along the object's yaw and across it (the better of the two counts, as a policy
that tries both rotations). With the low-object rule (and the sim's firm squeeze) nearly all are
lifted; with DESIGN section 4's rule alone (fingertips at grasp_min_z = 12 mm, above them) none is.
"""

from dataclasses import replace

import numpy as np
import pytest

from pg_core import heightmap as hm
from pg_core.action_geometry import grasp_z
from pg_sim.objects.catalog import object_spec
from pg_sim.scenes.meshes import mesh_extents
from pg_sim.scenes.scene import SceneSpec
from pg_sim.world.primitives import PrimitiveExecutor
from pg_sim.world.world import World

# (object id, x, y, yaw): a 4.6 mm card, a knife (5 mm blade, 12 mm handle), a 3 mm blade pair, pens of 12 and 8 mm,
# a 15 mm block and a 20 mm ellipsoid, spread over the workspace.
PLACEMENTS = (
    ("thin/801", 0.0, 0.0, 0.3),
    ("thin/802", 0.1, 0.12, -0.8),
    ("thin/810", -0.15, -0.05, 2.0),
    ("rod/800", 0.08, -0.1, 1.2),
    ("rod/805", -0.1, 0.1, -0.4),
    ("small/800", 0.12, 0.02, 0.7),
    ("small/809", -0.05, -0.15, -1.9),
)


@pytest.fixture(scope="module")
def world():
    w = World()
    yield w
    w.close()


def _lifted(world: World, object_id: str, x: float, y: float, yaw: float, prims) -> bool:
    """Whether a grasp at the object's centre, along its yaw or across it, lifts it (either rotation)."""
    for turn in (0.0, np.pi / 2):
        spec = object_spec(object_id, (89, 161, 79), (x, y, 0.0, 0.0, 0.0, yaw), "target", target=True)
        spec = replace(spec, pose=(x, y, mesh_extents(spec.mesh)[2] / 2 + 5e-4, 0.0, 0.0, yaw))
        world.load_scene(SceneSpec("low-object", "green", (spec,), family="test"))
        cx, cy, _, _, _, cyaw = world.object_poses()[world.target_id]
        obs = world.observe()
        r, c = hm.world_to_pixel(cx, cy, obs.heightmap.bounds, obs.heightmap.resolution)
        z = grasp_z(obs.heightmap.height, r, c, prims)
        if PrimitiveExecutor(world).grasp(float(cx), float(cy), z, float(cyaw + turn)).target_grasped:
            return True
    return False


def test_low_objects_are_grasped_with_the_low_object_rule(world):
    prims = world.geometry.primitives
    ok = {oid: _lifted(world, oid, x, y, yaw, prims) for oid, x, y, yaw in PLACEMENTS}
    assert sum(ok.values()) >= len(PLACEMENTS) - 1, ok


def test_section_4_rule_alone_closes_above_them(world):
    section4 = replace(world.geometry.primitives, grasp_low_heights=(0.0, 0.0))
    ok = {oid: _lifted(world, oid, x, y, yaw, section4) for oid, x, y, yaw in PLACEMENTS}
    assert sum(ok.values()) <= 1, ok
