"""Household families (household-N, household-hard-N, household-hard-A-N, train-...) and the arrangements of the hard
ones."""

from __future__ import annotations

import math
import zlib

import numpy as np
import pytest

from pg_core.geometry import load as load_geometry
from pg_sim.objects.catalog import HOUSEHOLD_KINDS, household_info, split_of
from pg_sim.scenes.colors import PALETTE
from pg_sim.world import arrangements
from pg_sim.world.arrangements import ARRANGEMENT_NAMES, ARRANGEMENTS, KEEP_CLEAR_M, arrangement_of
from pg_sim.world.scene_families import check_generated, household_pool, sample_family, target_kind


def _object_id(name: str) -> str:
    _, category, index = name.split("-")[:3]
    return f"{category}/{index}"


def test_workspace_half_extent_is_the_config_s():
    ws = load_geometry().workspace
    assert ws.x == pytest.approx((-arrangements.WORKSPACE_HALF, arrangements.WORKSPACE_HALF))
    assert ws.y == pytest.approx((-arrangements.WORKSPACE_HALF, arrangements.WORKSPACE_HALF))


def test_hard_families_need_room_for_their_arrangement():
    assert check_generated("household-hard-8") == ("household-hard", 8)
    assert check_generated("household-3") == ("household", 3)
    with pytest.raises(ValueError, match="6 to 40"):
        check_generated("household-hard-5")


@pytest.mark.parametrize("family,split", [("household-10", "heldout"), ("household-hard-8", "heldout"),
                                          ("train-household-10", "train"), ("train-household-hard-8", "train")])
def test_household_families_draw_their_split_only(family, split):
    base = 1_000_000 if split == "heldout" else 0
    for seed in range(base, base + 12):
        scene = sample_family(family, seed)
        assert len(scene.objects) == int(family.rsplit("-", 1)[1])
        assert all(split_of(_object_id(o.name)) == split for o in scene.objects)
        assert scene.target_object.color == PALETTE["green"]
        assert sum(o.color == PALETTE["green"] for o in scene.objects) == 1
        assert scene.target_object.name.startswith("obj0-")
        assert target_kind(scene.target_object.name) in (*HOUSEHOLD_KINDS, "named")


def test_same_seed_same_scene_and_the_pools_are_disjoint():
    assert sample_family("household-hard-8", 1_000_007) == sample_family("household-hard-8", 1_000_007)
    assert sample_family("household-hard-8", 1_000_007) != sample_family("household-hard-8", 1_000_013)
    train, held = household_pool("train"), household_pool("heldout")
    assert set(train) == set(held)
    assert all(not set(train[c]) & set(held[c]) for c in train)


@pytest.mark.parametrize("name", ARRANGEMENT_NAMES)
def test_a_family_of_one_arrangement_arranges_every_scene_so(name):
    family = f"train-household-hard-{name}"
    assert check_generated(f"{family}-8") == (family, 8)
    rng_name = f"{family}-8".encode()
    for seed in range(5000, 5006):  # seeds of every arrangement in the mixed family: this one every time
        scene = sample_family(f"{family}-8", seed)
        assert all(split_of(_object_id(o.name)) == "train" for o in scene.objects)
        rng = np.random.default_rng([seed, zlib.crc32(rng_name)])
        pool = household_pool("train")
        placed = ARRANGEMENTS[name](rng, {c: pool[c] for c in HOUSEHOLD_KINDS}).placed
        assert {_object_id(o.name) for o in scene.objects} >= {p.object_id for p in placed}
    assert check_generated(f"household-hard-{name}-8") == (f"household-hard-{name}", 8)
    with pytest.raises(ValueError, match="unknown arrangement"):
        arrangements.arranged_objects(np.random.default_rng(0), {}, 8, 0, [], (0, 255, 0), lambda r: "", "floating")


def test_every_arrangement_in_six_consecutive_seeds():
    assert sorted(arrangement_of(s) for s in range(1_000_000, 1_000_006)) == sorted(ARRANGEMENT_NAMES)


def _xy(spec) -> np.ndarray:
    return np.array(spec.pose[:2])


@pytest.mark.parametrize("offset", range(6))
def test_arrangements_place_the_target_as_named(offset):
    seed = 1_000_000 + offset
    kind = arrangement_of(seed)
    scene = sample_family("household-hard-8", seed)
    objs = list(scene.objects)
    target = scene.target_object
    info = household_info(_object_id(target.name))
    rng = np.random.default_rng([seed, zlib.crc32(b"household-hard-8")])  # the family's draw (scene_families)
    pool = household_pool("heldout")
    n_placed = len(ARRANGEMENTS[kind](rng, {c: pool[c] for c in HOUSEHOLD_KINDS}).placed)
    placed, clutter = objs[:n_placed], objs[n_placed:]
    assert target in placed
    if kind == "under":  # a neighbour spawned after the target, above it and overlapping it
        cover = placed[placed.index(target) + 1]
        assert cover.pose[2] > target.pose[2]
        assert np.linalg.norm(_xy(cover) - _xy(target)) < info.length
    elif kind in ("inside", "holding"):
        container, filler = placed[0], placed[1]
        assert (target is filler) == (kind == "inside")
        assert household_info(_object_id(container.name)).container
        cinfo, finfo = household_info(_object_id(container.name)), household_info(_object_id(filler.name))
        floor = container.pose[2] - cinfo.extents[2] / 2 + cinfo.extents[2] - cinfo.inner_depth
        assert np.allclose(_xy(container), _xy(filler)) and filler.pose[2] - finfo.extents[2] / 2 > floor
    elif kind == "leaning":
        support = placed[0]
        assert placed[1] is target and abs(target.pose[3]) + abs(target.pose[4]) > 0.1  # tilted
        assert np.linalg.norm(_xy(support) - _xy(target)) < 0.3
    elif kind == "thin":
        assert sum(household_info(_object_id(o.name)).thin for o in placed if o is not target) >= 4
    else:  # edge: the footprint's half diagonal ends 1-2.5 cm inside the workspace edge
        reach = max(abs(target.pose[0]), abs(target.pose[1])) + math.hypot(*info.extents[:2]) / 2
        assert arrangements.WORKSPACE_HALF - 0.026 < reach < arrangements.WORKSPACE_HALF - 0.009
    anchor = _xy(target) if kind != "inside" else _xy(placed[0])
    for o in clutter:
        if kind not in ("leaning",):
            assert np.linalg.norm(_xy(o) - anchor) >= KEEP_CLEAR_M - 1e-9 or kind == "holding"


def test_settled_arrangements_keep_their_relation():
    """Physics: after dropping, the target is inside its container, under its neighbour (partly hidden from the
    camera) or at the edge, as the arrangement says, for the first seed of each arrangement."""
    from pg_sim.world.scene_families import generate_scene
    from pg_sim.world.world import World

    with World() as world:
        for seed in range(1_000_000, 1_000_006):
            kind = arrangement_of(seed)
            scene = generate_scene(world, "household-hard-6", seed)
            poses = {world.objects[b].name: pose for b, pose in world.object_poses().items()}
            target = scene.target_object
            t = np.asarray(poses[target.name])
            assert abs(t[0]) < 0.224 and abs(t[1]) < 0.224, f"{kind}: target left the workspace"
            if kind in ("inside", "holding"):
                container, filler = scene.objects[0], scene.objects[1]
                c, f = np.asarray(poses[container.name]), np.asarray(poses[filler.name])
                inner = household_info(_object_id(container.name)).inner_radius
                assert np.linalg.norm(c[:2] - f[:2]) < inner, f"{kind}: the filler fell out"
            if kind == "under":
                visible = (world.observe().frame.segmentation == world.target_id).sum()
                assert visible > 0
