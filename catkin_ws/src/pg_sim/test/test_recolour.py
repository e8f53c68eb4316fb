"""pg_sim.world.recolour: scene colour variants (repeated, same) drawn from the trial seed, painted into the bodies and
kept in the world's object specs and scene, the target staying the same body."""

from __future__ import annotations

import pybullet as p
import pytest

from pg_sim.scenes.colors import COLORS, resolve_color, rgba
from pg_sim.scenes.scene import ObjectSpec, SceneSpec
from pg_sim.world.recolour import REPEATED, SAME, UNIQUE, draw_colours, recolour
from pg_sim.world.world import World

SEEDS = range(1_000_000, 1_000_040)


@pytest.mark.parametrize("n", [2, 3, 10])
def test_repeated_gives_another_object_the_targets_colour_and_same_one_colour(n):
    for seed in SEEDS:
        target = seed % n
        colours = draw_colours(n, target, REPEATED, seed)
        assert colours is not None and len(colours) == n and set(colours) <= set(COLORS)
        assert colours.count(colours[target]) >= 2
        same = draw_colours(n, target, SAME, seed)
        assert same is not None and len(set(same)) == 1 and same[0] in COLORS


def test_draws_are_deterministic_per_seed_and_vary_between_seeds():
    assert draw_colours(10, 3, REPEATED, 1_000_007) == draw_colours(10, 3, REPEATED, 1_000_007)
    assert len({tuple(draw_colours(10, 3, REPEATED, s) or ()) for s in SEEDS}) > 30
    assert len({(draw_colours(5, 0, SAME, s) or [""])[0] for s in SEEDS}) > 3
    assert draw_colours(10, 3, UNIQUE, 1_000_007) is None


def test_bad_arguments_are_refused():
    with pytest.raises(ValueError, match="unknown colour mode 'pastel'"):
        draw_colours(3, 0, "pastel", 1)
    with pytest.raises(ValueError, match="at least 2 objects"):
        draw_colours(1, 0, REPEATED, 1)
    with pytest.raises(ValueError, match="target index 3"):
        draw_colours(3, 3, SAME, 1)


def _scene() -> SceneSpec:
    names = ("a", "b", "target", "c")
    objs = tuple(ObjectSpec("cube", None, resolve_color(c), (-0.09 + 0.06 * i, 0.0, 0.0226, 0, 0, 0), name=n,
                            target=n == "target")
                 for i, (n, c) in enumerate(zip(names, ("blue", "red", "green", "yellow"), strict=True)))
    return SceneSpec("four", "green", objs, "test")


def test_recolour_paints_the_bodies_and_keeps_specs_scene_and_target_true():
    with World() as world:
        world.load_scene(_scene(), settle=False)
        target = world.target_id
        painted = recolour(world, REPEATED, 1_000_003)
        assert world.target_id == target and list(painted) == list(world.objects)
        assert list(painted.values()).count(painted[target]) >= 2
        for body, name in painted.items():
            assert world.objects[body].color == COLORS[name]
            shown = p.getVisualShapeData(body, physicsClientId=world.client)[0][7]
            assert shown == pytest.approx(rgba(COLORS[name]), abs=1e-6)
        assert world.scene is not None and world.scene.target == painted[target]
        by_name = {world.objects[b].name: COLORS[c] for b, c in painted.items()}
        assert {o.name: o.color for o in world.scene.objects} == by_name
        assert world.scene.target_object.name == "target"

        world.load_scene(_scene(), settle=False)  # the same scene and seed paint the same colours
        again = recolour(world, REPEATED, 1_000_003)
        assert list(again.values()) == list(painted.values())
        world.load_scene(_scene(), settle=False)
        same = recolour(world, SAME, 1_000_003)
        assert len(set(same.values())) == 1
        world.load_scene(_scene(), settle=False)
        assert recolour(world, UNIQUE, 1_000_003) == {}
        assert [s.color for s in world.objects.values()] == [o.color for o in _scene().objects]
