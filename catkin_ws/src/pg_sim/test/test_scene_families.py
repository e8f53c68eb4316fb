"""Generated scene families (novel-N, novel-packed-N, mixed-N, train-...) and the shared-target-colour rule."""

from __future__ import annotations

import pytest

from pg_sim.objects.catalog import split_of
from pg_sim.scenes.colors import PALETTE
from pg_sim.scenes.scene import SceneError, parse_scene
from pg_sim.scenes.scene_writer import scene_to_dict
from pg_sim.world.scene_families import FAMILIES, check_generated, parse_generated, sample_family, target_kind


def _object_id(name: str) -> str | None:
    parts = name.split("-")
    return f"{parts[1]}/{parts[2]}" if len(parts) == 3 else None


def test_family_names_parse():
    assert parse_generated("novel-packed-8") == ("novel-packed", 8)
    assert parse_generated("novel-10") == ("novel", 10)
    assert parse_generated("train-mixed-15") == ("train-mixed", 15)
    assert parse_generated("random-10") == ("random", 10)
    assert parse_generated("packed/case01") is None and parse_generated("novel-") is None
    with pytest.raises(ValueError, match="1 to 40"):
        check_generated("novel-0")
    with pytest.raises(ValueError, match="not a generated scene"):
        check_generated("novel-packed")


@pytest.mark.parametrize("family", ["novel-10", "novel-packed-8", "mixed-15"])
def test_evaluation_families_draw_held_out_objects_only(family):
    for seed in range(1_000_000, 1_000_005):
        scene = sample_family(family, seed)
        ids = [_object_id(o.name) for o in scene.objects]
        assert all(split_of(i) == "heldout" for i in ids if i is not None)
        assert scene.target_object.color == PALETTE["green"]
        assert sum(o.color == PALETTE["green"] for o in scene.objects) == 1
        if family.startswith("mixed"):
            assert any(i is None for i in ids) and any(i is not None for i in ids)
        else:
            assert all(i is not None for i in ids)


@pytest.mark.parametrize("family", ["train-novel-10", "train-novel-packed-8", "train-mixed-10"])
def test_training_families_draw_training_objects_only(family):
    for seed in range(5):
        ids = [_object_id(o.name) for o in sample_family(family, seed).objects]
        assert all(split_of(i) == "train" for i in ids if i is not None)


def test_same_seed_same_scene_and_block_families_unchanged():
    assert sample_family("novel-10", 1_000_003) == sample_family("novel-10", 1_000_003)
    assert sample_family("novel-10", 1_000_003) != sample_family("novel-10", 1_000_004)
    names = lambda fam: [o.name.split("-", 1)[1] for o in sample_family(fam, 1_000_003).objects]  # noqa: E731
    assert names("novel-10")[:8] != names("novel-packed-8")  # families do not share their draws
    from pg_sim.world.random_scene import sample_drops

    assert sample_family("random-10", 7) == sample_drops(10, 7)
    assert sample_family("dense-8", 7) == sample_drops(8, 7, half_extent=0.05)


def test_every_kind_is_a_target_in_the_protocol_seeds():
    kinds = {target_kind(sample_family("novel-10", s).target_object.name) for s in range(1_000_000, 1_000_100)}
    assert kinds == {"thin", "rod", "rolling", "concave", "small", "wide", "blob", "named"}
    assert FAMILIES["novel-packed"].half_extent < FAMILIES["novel"].half_extent


def test_generated_scene_round_trips_through_yaml(tmp_path):
    from pg_sim.scenes.scene import load_scene
    from pg_sim.scenes.scene_writer import save_scene

    scene = sample_family("mixed-6", 1_000_010)
    back = load_scene(save_scene(scene, tmp_path / "s.yaml"))
    assert [o.mass for o in back.objects] == [o.mass for o in scene.objects]
    assert [o.mesh for o in back.objects] == [o.mesh for o in scene.objects]


def test_shared_target_colour_is_refused_naming_both_objects():
    raw = {"name": "two_greens", "target": "green", "objects": [
        {"shape": "cube", "color": "green", "pose": [0, 0, 0.03, 0, 0, 0], "target": True, "name": "goal"},
        {"shape": "cube", "color": "blue", "pose": [0.1, 0, 0.03, 0, 0, 0]},
        {"shape": "rect", "color": "green", "pose": [-0.1, 0, 0.03, 0, 0, 0], "name": "twin"},
    ]}
    with pytest.raises(SceneError, match=r"object 2 \('twin'\).*object 0 \('goal'\).*ambiguous"):
        parse_scene(raw)
    raw["objects"][2]["color"] = "red"
    assert parse_scene(raw).target_object.name == "goal"


def test_mass_key_is_validated_and_kept():
    raw = {"objects": [{"shape": "cube", "color": "green", "pose": [0, 0, 0.03, 0, 0, 0], "mass": 0.2}]}
    scene = parse_scene(raw)
    assert scene.objects[0].mass == 0.2 and scene_to_dict(scene)["objects"][0]["mass"] == 0.2
    for bad in (-1, 0, 1e6, "heavy", True):
        raw["objects"][0]["mass"] = bad
        with pytest.raises(SceneError, match="mass must be"):
            parse_scene(raw)


def test_novel_scene_settles_with_the_target_in_view():
    from pg_sim.world.scene_families import generate_scene
    from pg_sim.world.world import World

    with World() as world:
        scene = generate_scene(world, "novel-packed-5", 1_000_002)
        obs = world.observe()
        visible = int((world.label_heightmap(obs.frame) == world.target_id).sum())
        assert len(world.objects) == 5 and scene.family == "novel-packed"
        assert visible > 20
