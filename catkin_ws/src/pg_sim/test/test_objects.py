"""The object catalogue: ids, splits, generated kinds' dimensions, cached meshes, masses (no ROS)."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

from pg_sim.objects import generated
from pg_sim.objects.catalog import (
    GENERATED_KINDS,
    KINDS,
    NAMED_HELD_OUT,
    object_ids,
    object_spec,
    parse_id,
    split_of,
)
from pg_sim.objects.pybullet_assets import BLOB_COUNT, BROKEN_BLOBS, data_path
from pg_sim.scenes.meshes import collision_file, load_obj
from pg_sim.scenes.shapes import HULL_MARGIN


def test_splits_are_disjoint_and_cover_every_kind():
    train, held = object_ids("train"), object_ids("heldout")
    assert set(train) == set(held) == set(KINDS)
    for kind in KINDS:
        assert train[kind] and held[kind]
        assert not set(train[kind]) & set(held[kind]), kind
        assert all(split_of(i) == "train" for i in train[kind])
        assert all(split_of(i) == "heldout" for i in held[kind])
    assert {i.split("/")[1] for i in held["named"]} == set(NAMED_HELD_OUT)
    assert held["thin"][0] == "thin/800" and train["blob"][-1] == "blob/799"


@pytest.mark.parametrize("bad", ["thin", "thin/1000", "thin/-1", "cube/3", "named/dragon", "x" * 5000])
def test_bad_object_ids_are_refused(bad):
    with pytest.raises(ValueError) as err:
        parse_id(bad)
    assert len(str(err.value)) < 300


def test_broken_pybullet_blobs_are_left_out_and_refused():
    """The installed pybullet_data's blobs with a non-finite vertex are exactly BROKEN_BLOBS; the catalogue lists
    none of them, asking for one is a clear error, and load_obj refuses such a file."""
    broken = set()
    for i in range(BLOB_COUNT):
        text = blob_path_unchecked(i).read_text(encoding="utf-8", errors="replace")
        rows = [ln.split()[1:4] for ln in text.splitlines() if ln.startswith("v ")]
        if not np.isfinite(np.asarray(rows, dtype=np.float64)).all():
            broken.add(i)
    assert broken == set(BROKEN_BLOBS)
    listed = {int(i.split("/")[1]) for split in ("train", "heldout") for i in object_ids(split, ("blob",))["blob"]}
    assert not listed & broken and len(listed) == BLOB_COUNT - len(broken)
    for i in sorted(broken):
        with pytest.raises(ValueError, match="non-finite"):
            object_spec(f"blob/{i}", (0, 255, 0), (0.0, 0.0, 0.02, 0.0, 0.0, 0.0), "b")
        with pytest.raises(ValueError, match="not finite"):
            load_obj(blob_path_unchecked(i))


def test_unknown_split_or_kind_is_refused():
    with pytest.raises(ValueError, match="unknown split"):
        object_ids("test")
    with pytest.raises(ValueError, match="unknown object kind"):
        object_ids("train", ("thin", "spork"))


def blob_path_unchecked(index: int):
    return data_path(f"random_urdfs/{index:03d}/{index:03d}.obj")


def _dims(kind: str, index: int) -> np.ndarray:
    rng = np.random.default_rng(index)
    parts, _ = generated.build(kind, rng)
    mesh = trimesh.util.concatenate(parts)
    return np.sort(mesh.extents)


@pytest.mark.parametrize("index", range(12))
def test_generated_kinds_have_the_documented_dimensions(index):
    thin = _dims("thin", index)
    assert 0.003 <= thin[0] <= 0.012 and thin[2] >= 0.05  # 3-12 mm tall, long
    rod = _dims("rod", index)
    assert rod[1] <= 0.017 and rod[2] >= 0.085
    small = _dims("small", index)
    assert small[2] < 0.025
    wide = _dims("wide", index)
    assert wide[2] > 0.085 and wide[1] <= 0.061  # wider than the open jaw in one direction only
    rolling = _dims("rolling", index)
    assert 0.02 <= rolling[0] <= 0.08


def test_concave_objects_are_concave_compounds_of_convex_parts():
    for index in range(6):
        parts, _ = generated.build("concave", np.random.default_rng(index))
        assert len(parts) > 5 and all(p.is_convex for p in parts)
        assert all(generated.inset(p).volume < p.volume for p in parts)
        union = trimesh.util.concatenate(parts)
        hull = union.convex_hull.volume
        assert sum(p.volume for p in parts) < 0.6 * hull  # walls and a bottom, not a solid


def test_object_spec_is_deterministic_and_cached(tmp_path, monkeypatch):
    monkeypatch.setenv("PUSHGRASP_CACHE", str(tmp_path))
    a = object_spec("concave/812", (89, 161, 79), (0, 0, 0.1, 0, 0, 0), "cup", target=True)
    text = open(a.mesh).read()
    b = object_spec("concave/812", (89, 161, 79), (0, 0, 0.1, 0, 0, 0), "cup", target=True)
    assert a == b and open(b.mesh).read() == text
    assert a.mesh.startswith(str(tmp_path)) and a.shape == "mesh" and a.target
    assert load_obj(a.mesh).objects > 5  # one group per convex part: PyBullet loads the exact compound
    col = load_obj(collision_file(a.mesh))
    assert col.objects == load_obj(a.mesh).objects
    ext = np.ptp(load_obj(a.mesh).vertices, axis=0) - np.ptp(col.vertices, axis=0)
    # every face moves in by Bullet's margin: the height by exactly 2 margins, the walls' slanted corners a little more
    assert abs(ext[2] - 2 * HULL_MARGIN) < 1e-6 and np.all((ext > 1.9 * HULL_MARGIN) & (ext < 3.5 * HULL_MARGIN))
    assert object_spec("concave/813", (1, 2, 3), (0,) * 6, "x").mesh != a.mesh


@pytest.mark.parametrize("object_id", ["named/duck", "named/jenga", "blob/812", "thin/3", "small/900"])
def test_masses_are_realistic(object_id):
    spec = object_spec(object_id, (1, 2, 3), (0,) * 6, "o")
    assert spec.mass is not None and 0.005 <= spec.mass <= 0.4


def test_every_kind_builds_in_pybullet():
    import pybullet as p

    from pg_sim.scenes.objects import spawn_object

    client = p.connect(p.DIRECT)
    try:
        for kind in GENERATED_KINDS:
            spec = object_spec(f"{kind}/850", (1, 2, 3), (0, 0, 0.1, 0, 0, 0), kind)
            body = spawn_object(client, spec)
            assert abs(p.getDynamicsInfo(body, -1, physicsClientId=client)[0] - spec.mass) < 1e-9
    finally:
        p.disconnect(client)


def test_pybullet_meshes_lose_their_materials():
    # a texture (the torus has a multicoloured one, green included) would override the scene's colour
    spec = object_spec("named/torus", (1, 2, 3), (0,) * 6, "o")
    text = open(spec.mesh).read()
    assert "mtllib" not in text and "usemtl" not in text and text.count("\nf ") > 100
