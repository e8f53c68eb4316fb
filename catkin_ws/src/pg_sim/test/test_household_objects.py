"""Household objects of the catalogue: ids and splits, held-out parameters, meshes, sizes, masses, friction, physics.

Physics checks spawn objects in the PyBullet World at their resting pose (no ROS).
"""

from __future__ import annotations

import math

import numpy as np
import pybullet as p
import pytest

from pg_sim.objects import household
from pg_sim.objects.catalog import (
    HOUSEHOLD_KINDS,
    KINDS,
    household_ids,
    household_info,
    object_ids,
    object_spec,
    parse_id,
    split_of,
)
from pg_sim.scenes.meshes import collision_file, load_obj
from pg_sim.scenes.scene import ObjectSpec, SceneError, load_scene, parse_scene
from pg_sim.scenes.scene_writer import save_scene
from pg_sim.world.world import World

JAW_OPENING = 0.085  # m, pg_description workspace.yaml gripper max opening
# category -> (canonical extent measured against the main dimension: axis index, relative tolerance); fruit has none
MAIN_EXTENT = {
    "bowl": (0, 1e-6), "plate": (0, 1e-6), "cup": (2, 1e-6), "mug": (2, 1e-6), "bottle": (2, 1e-6),
    "can": (2, 1e-6), "spoon": (0, 0.01), "fork": (0, 0.01), "knife": (0, 0.01), "spatula": (0, 0.01),
    "screwdriver": (0, 0.01), "scissors": (0, 0.06), "pliers": (0, 0.02), "hammer": (0, 0.01),
    "toy_airplane": (0, 1e-6), "toy_car": (0, 1e-6),
}
# category -> (lo, hi) kg: real masses
MASSES = {
    "bowl": (0.08, 0.6), "plate": (0.1, 0.6), "cup": (0.05, 0.4), "mug": (0.15, 0.45), "bottle": (0.05, 0.6),
    "can": (0.05, 0.6), "spoon": (0.015, 0.08), "fork": (0.015, 0.08), "knife": (0.02, 0.2), "spatula": (0.03, 0.15),
    "screwdriver": (0.03, 0.2), "scissors": (0.02, 0.15), "pliers": (0.05, 0.3), "hammer": (0.1, 0.6),
    "toy_airplane": (0.01, 0.2), "toy_car": (0.01, 0.2), "brick": (0.005, 0.05), "fruit": (0.05, 0.3),
}


def test_household_ids_and_splits():
    assert len(HOUSEHOLD_KINDS) == 18 and not set(HOUSEHOLD_KINDS) & set(KINDS)
    assert all("-" not in c for c in HOUSEHOLD_KINDS)
    assert KINDS == ("thin", "rod", "rolling", "concave", "small", "wide", "blob", "named")  # families draw from these
    assert set(object_ids("train")) == set(KINDS)
    train, held = household_ids("train"), household_ids("heldout")
    assert set(train) == set(held) == set(HOUSEHOLD_KINDS)
    for kind in HOUSEHOLD_KINDS:
        assert train[kind] == [f"{kind}/{i}" for i in range(80)]
        assert held[kind] == [f"{kind}/{i}" for i in range(80, 100)]
        assert {split_of(i) for i in train[kind]} == {"train"} and {split_of(i) for i in held[kind]} == {"heldout"}
    assert object_ids("heldout", ("bowl", "thin"))["bowl"] == held["bowl"]
    assert parse_id("toy_airplane/99") == ("toy_airplane", "99")


@pytest.mark.parametrize("bad", ["spork/1", "bowl/100", "bowl/-1", "bowl/x", "toy-car/3", "bowl"])
def test_bad_household_ids_are_refused(bad):
    with pytest.raises(ValueError) as err:
        parse_id(bad)
    message = str(err.value)
    assert len(message) < 300
    if not bad.startswith("bowl/"):
        assert "bowl" in message and "toy_airplane" in message and "fruit" in message
    with pytest.raises(ValueError, match="not a household object"):
        household_info("thin/3")
    with pytest.raises(ValueError, match="unknown object kind"):
        object_ids("train", ("spork",))


@pytest.mark.parametrize("category", HOUSEHOLD_KINDS)
def test_held_out_parameters_are_disjoint_from_training(category):
    cat = household.CATEGORIES[category]
    train = [household.split_params(category, i) for i in range(household.HELD_OUT_FROM)]
    held = [household.split_params(category, i) for i in range(household.HELD_OUT_FROM, household.INDEX_COUNT)]
    lo, hi = cat.held
    assert cat.span[0] <= lo < hi <= cat.span[1]
    assert all(cat.span[0] <= m <= cat.span[1] and not lo <= m < hi for m, _ in train)
    assert all(lo <= m < hi for m, _ in held)
    assert not {m for m, _ in train} & {m for m, _ in held}
    assert not {v for _, v in train} & set(cat.held_variants)
    assert {v for _, v in train} | {v for _, v in held} <= set(cat.variants)
    assert household.split_params(category, 7) == train[7]  # seeded by the id


def test_objects_are_deterministic_and_cached(tmp_path, monkeypatch):
    monkeypatch.setenv("PUSHGRASP_CACHE", str(tmp_path))
    a, b = household.build("mug", 12), household.build("mug", 12)
    assert a.params == b.params and np.array_equal(a.visual.vertices, b.visual.vertices)
    assert household.build("mug", 13).params != a.params
    s1 = object_spec("mug/12", (1, 2, 3), (0.0, 0.0, 0.05, 0.0, 0.0, 0.0), "m")
    text = open(s1.mesh).read()
    s2 = object_spec("mug/12", (1, 2, 3), (0.0, 0.0, 0.05, 0.0, 0.0, 0.0), "m")
    assert s1 == s2 and s1.mesh.startswith(str(tmp_path)) and open(s2.mesh).read() == text
    assert s1.mass == pytest.approx(household_info("mug/12").mass) and s1.friction == household_info("mug/12").friction
    assert load_obj(collision_file(s1.mesh)).objects == len(a.parts)  # one group per convex piece
    assert load_obj(s1.mesh).objects == 1


@pytest.mark.parametrize("category", HOUSEHOLD_KINDS)
def test_meshes_sizes_and_masses(category):
    for index in (5, 93):
        model = household.build(category, index)
        info, main = model.info, model.params[household.CATEGORIES[category].main]
        assert model.visual.is_watertight and model.visual.volume > 0
        assert all(part.is_convex for part in model.parts)
        ext = model.visual.extents
        if category in MAIN_EXTENT:
            axis, tol = MAIN_EXTENT[category]
            assert ext[axis] == pytest.approx(main, rel=tol, abs=1e-6), (category, index)
        assert min(info.extents) <= JAW_OPENING  # the jaw closes across it somewhere
        assert info.length == pytest.approx(max(info.extents)) and max(info.extents) <= 0.3
        assert MASSES[category][0] <= info.mass <= MASSES[category][1], (category, index, info.mass)
        lo, hi = household.CATEGORIES[category].friction
        assert lo <= info.friction <= hi
        assert info.container == (category in ("bowl", "plate", "cup", "mug"))
        if info.container:  # the cavity: much less volume than the solid hull
            assert model.visual.volume < 0.5 * model.visual.convex_hull.volume
            assert 0.02 < info.inner_radius < ext[0] / 2 and 0.003 < info.inner_depth < ext[2]
    assert household_info(f"{category}/93").extents == pytest.approx(household.build(category, 93).info.extents)


def test_real_dimensions_of_details():
    knife = household.build("knife", 3)
    assert 0.001 <= knife.params["blade_thickness"] <= 0.003
    mug = household.build("mug", 40)
    assert mug.params["handle_reach"] - mug.params["handle_thickness"] >= 0.015  # a finger goes through
    assert 0.07 <= mug.info.extents[2] <= 0.11 and 0.07 <= mug.info.extents[1] <= 0.085
    spoon = household.build("spoon", 40)
    assert 0.15 <= spoon.info.length <= 0.20
    for i in range(0, 100, 9):  # hammers at most 0.30 m, bowls 0.10-0.20, plates 0.15-0.26
        assert household_info(f"hammer/{i}").length <= 0.30
        assert 0.10 <= household_info(f"bowl/{i}").extents[0] <= 0.20
        assert 0.15 <= household_info(f"plate/{i}").extents[0] <= 0.26
    bottle = [household_info(f"bottle/{i}") for i in range(10)]
    assert {b.rest_rpy for b in bottle} == {(0.0, 0.0, 0.0), (0.0, math.pi / 2, 0.0)}  # standing and lying


def _tilt(client: int, body: int, rpy: tuple[float, float, float]) -> float:
    """Angle (deg) between a body's orientation and ``rpy``."""
    _, q = p.getBasePositionAndOrientation(body, physicsClientId=client)
    r = np.array(p.getMatrixFromQuaternion(q)).reshape(3, 3)
    r0 = np.array(p.getMatrixFromQuaternion(p.getQuaternionFromEuler(rpy))).reshape(3, 3)
    return math.degrees(math.acos(np.clip((np.trace(r0.T @ r) - 1) / 2, -1.0, 1.0)))


def test_objects_rest_stably_at_their_rest_pose():
    with World() as world:
        for category in HOUSEHOLD_KINDS:
            for index in (2, 88):
                object_id = f"{category}/{index}"
                info = household_info(object_id)
                rpy = (info.rest_rpy[0], info.rest_rpy[1], 0.6)
                world.clear_objects()
                body = world.add_object(object_spec(object_id, (200, 60, 60), (0.05, -0.04, info.extents[2] / 2 +
                                                                               0.002, *rpy), "o"))
                world.settle(max_time=2.0)
                for _ in range(240):  # a further second: nothing creeps
                    world.step()
                pos, _ = p.getBasePositionAndOrientation(body, physicsClientId=world.client)
                assert math.hypot(pos[0] - 0.05, pos[1] + 0.04) < 0.005, object_id
                assert abs(pos[2] - info.extents[2] / 2) < 0.005, object_id  # neither sunk nor fallen through
                # bbox-centred mass: a screwdriver leans a few degrees onto its tip, everything else stays put
                assert _tilt(world.client, body, rpy) < (8.0 if category == "screwdriver" else 2.0), object_id


@pytest.mark.parametrize("object_id", ["bowl/7", "cup/84", "mug/3", "plate/91"])
def test_a_small_cube_stays_in_a_container(object_id):
    info = household_info(object_id)
    with World() as world:
        bowl = world.add_object(object_spec(object_id, (230, 230, 230), (0.0, 0.0, info.extents[2] / 2, *info.rest_rpy),
                                            "container"))
        world.settle()
        drop = (0.006, -0.004, info.extents[2] + 0.03, 0.4, 0.2, 0.1)
        cube = world.add_object(ObjectSpec("cube", (0.02, 0.02, 0.02), (40, 200, 40), drop, name="cube", mass=0.02))
        world.settle(max_time=3.0)
        (cx, cy, cz), _ = p.getBasePositionAndOrientation(cube, physicsClientId=world.client)
        (bx, by, _), _ = p.getBasePositionAndOrientation(bowl, physicsClientId=world.client)
        assert math.hypot(cx - bx, cy - by) < info.inner_radius - 0.008  # inside the wall
        floor = info.extents[2] - info.inner_depth  # the inside bottom, above the table by the foot and bottom
        assert floor + 0.008 < cz < floor + 0.013, (object_id, cz, floor)  # resting on the inside bottom
        assert _tilt(world.client, bowl, info.rest_rpy) < 1.0  # the container still opens upwards


def test_friction_is_honoured_and_default_untouched():
    spec = object_spec("fruit/4", (200, 60, 60), (0.0, 0.0, 0.05, 0.0, 0.0, 0.0), "f")
    assert spec.friction is not None
    with World() as world:
        body = world.add_object(spec)
        assert p.getDynamicsInfo(body, -1, physicsClientId=world.client)[1] == pytest.approx(spec.friction)
        cube = world.add_object(ObjectSpec("cube", None, (40, 200, 40), (0.1, 0.1, 0.03, 0, 0, 0), name="cube"))
        assert p.getDynamicsInfo(cube, -1, physicsClientId=world.client)[1] == pytest.approx(0.7)  # Contact default


def test_scene_files_carry_friction(tmp_path):
    raw = {"name": "f", "objects": [{"shape": "cube", "color": "green", "pose": [0, 0, 0.0225, 0, 0, 0],
                                     "friction": 0.35, "name": "slippery"}]}
    scene = parse_scene(raw)
    assert scene.objects[0].friction == 0.35
    path = save_scene(scene, tmp_path / "f.yaml")
    assert "friction: 0.35" in path.read_text() and load_scene(path) == scene
    assert parse_scene({**raw, "objects": [{**raw["objects"][0], "friction": None}]}).objects[0].friction is None
    for bad in (0, -0.1, 2.5, float("nan"), "high", True):
        with pytest.raises(SceneError, match="slippery.*friction must be"):
            parse_scene({**raw, "objects": [{**raw["objects"][0], "friction": bad}]})


def test_cli_lists_household_categories_and_draws_a_gallery(tmp_path, capsys):
    import argparse

    from pg_sim.cli.scene import _household_gallery, _objects

    assert _objects(argparse.Namespace()) == 0
    out = capsys.readouterr().out
    assert all(f"{c}/80 .. {c}/99" in out for c in HOUSEHOLD_KINDS)
    assert _household_gallery(argparse.Namespace(out_dir=tmp_path, categories=["cup"])) == 0
    png = tmp_path / "cup.png"
    assert png.read_bytes()[:4] == b"\x89PNG" and png.stat().st_size < 150_000
    with pytest.raises(ValueError, match="unknown household categories"):
        _household_gallery(argparse.Namespace(out_dir=tmp_path, categories=["spork"]))
