"""Scene limits, YAML 1.2 numbers, allowed folders and bounded messages of scene files (pg_sim core, no ROS)."""

from __future__ import annotations

import textwrap
import time
from pathlib import Path

import pytest

from pg_sim.scenes.scene import SceneError, load_scene, parse_scene
from pg_sim.scenes.scene_folders import AllowedFolders, user_scene_dir
from pg_sim.scenes.scene_limits import DEFAULT_LIMITS, SceneLimits

CUBE = "  - {{shape: cube, size: [{s}, {s}, {s}], color: {c}, pose: [{x}, 0, 0.0225, 0, 0, 0]}}\n"


def scene_text(*objects: str) -> str:
    return "name: t\ntarget: green\nobjects:\n" + "".join(objects)


def write(folder: Path, text: str, name: str = "s.yaml") -> Path:
    path = folder / name
    path.write_text(textwrap.dedent(text))
    return path


def cube(size: object = 0.045, color: str = "green", x: object = 0.0) -> str:
    return CUBE.format(s=size, c=color, x=x)


@pytest.mark.parametrize(("obj", "patterns"), [
    (cube(size=1e6), ["object 0", "size", "1000000", "max_object_size 0.3"]),
    (cube(size="1e-9"), ["object 0", "size", "1e-09", "min_object_size 0.002"]),
    (cube(x="1e6"), ["object 0", "pose", "1000000", "outside the workspace", "max_pose_distance 0.5"]),
    (cube(x=-0.9), ["object 0", "pose", "-0.9", "max_pose_distance"]),
])
def test_objects_beyond_the_limits_are_refused_naming_field_and_value(tmp_path, obj, patterns):
    with pytest.raises(SceneError) as err:
        load_scene(write(tmp_path, scene_text(obj)))
    for pattern in patterns:
        assert pattern in str(err.value), (pattern, str(err.value))


def test_too_many_objects_are_refused_before_any_object_is_read(tmp_path):
    colors = ("red", "blue", "yellow", "orange", "purple")
    text = scene_text(cube(), *(cube(color=colors[i % 5], x=-0.2 + 0.4 * i / 500) for i in range(500)))
    t0 = time.perf_counter()
    with pytest.raises(SceneError, match=r"objects: 501 objects, at most 40 allowed \(max_objects\)"):
        load_scene(write(tmp_path, text))
    assert time.perf_counter() - t0 < 5.0
    many = SceneLimits(max_objects=600)
    assert len(load_scene(write(tmp_path, text), many).objects) == 501


def test_limits_are_configurable_and_checked():
    small = SceneLimits(max_objects=1, max_object_size=0.05, min_object_size=0.04, max_pose_distance=0.0)
    raw = {"objects": [{"shape": "cube", "color": "green", "pose": [0, 0, 0.02, 0, 0, 0]}]}
    assert parse_scene(raw, limits=small).objects[0].shape == "cube"
    with pytest.raises(SceneError, match="at most 1 allowed"):
        parse_scene({"objects": raw["objects"] * 2}, limits=small)
    with pytest.raises(SceneError, match="max_pose_distance 0 m"):
        parse_scene({"objects": [{**raw["objects"][0], "pose": [0.3, 0, 0.02, 0, 0, 0]}]}, limits=small)
    with pytest.raises(SceneError, match="larger than max_object_size 0.05"):
        parse_scene({"objects": [{**raw["objects"][0], "size": [0.06, 0.045, 0.045]}]}, limits=small)
    with pytest.raises(ValueError, match="min_object_size"):
        SceneLimits(min_object_size=0.5, max_object_size=0.1)
    with pytest.raises(ValueError, match="max_objects"):
        SceneLimits(max_objects=0)


def test_shipped_and_catalogue_sizes_are_within_the_default_limits():
    from pg_sim.objects.catalog import object_ids, object_spec
    from pg_sim.scenes.meshes import mesh_extents
    from pg_sim.scenes.scene import list_scenes

    names = list_scenes()
    assert {name.split("/")[0] for name in names} >= {"packed", "household"}
    for name in names:
        assert load_scene(name).objects, name  # load_scene refuses a scene beyond the limits (SceneError)
    lo, hi = DEFAULT_LIMITS.min_object_size, DEFAULT_LIMITS.max_object_size
    checked = 0
    for split in ("train", "heldout"):
        for kind, ids in object_ids(split).items():
            if kind in ("named", "blob"):
                for object_id in ids[:: max(1, len(ids) // 10)]:
                    spec = object_spec(object_id, (255, 0, 0), (0, 0, 0.05, 0, 0, 0), "o")
                    extents = mesh_extents(spec.mesh, spec.scale)
                    assert lo <= min(extents) and max(extents) <= hi, f"{object_id}: extents {extents}"
                    checked += 1
    assert checked >= 4  # both splits, both kinds


def test_exponent_numbers_read_as_numbers(tmp_path):
    text = scene_text("  - {shape: cube, size: [4.5e-2, 4.5E-2, 45e-3], color: green, mass: 8e-2,"
                      " pose: [0, 1e-3, 2.25e-2, 0, 0, 0]}\n")
    (obj,) = load_scene(write(tmp_path, text)).objects
    assert obj.size == pytest.approx((0.045, 0.045, 0.045)) and obj.mass == pytest.approx(0.08)
    assert obj.pose[1:3] == pytest.approx((0.001, 0.0225))
    with pytest.raises(SceneError, match="extent 1e\\+06 m is larger than max_object_size"):  # a number, not text
        load_scene(write(tmp_path, scene_text(cube(size="1e6"))))


def test_messages_are_bounded(tmp_path):
    long = "x" * 5000
    cases = [
        scene_text(cube(), f"  - {{shape: {long}, color: red, pose: [0, 0, 0, 0, 0, 0]}}\n"),
        scene_text(cube(), f"  - {{shape: cube, name: {long}, color: red, pose: [0, 0, 0, 0, 0, 0]}}\n",
                   f"  - {{shape: cube, name: {long}, color: blue, pose: [0, 0, 0, 0, 0, 0]}}\n"),
        scene_text(cube(), f"  - {{shape: cube, color: red, pose: [{', '.join(['0'] * 3000)}]}}\n"),
        scene_text(cube(), f"  - {{shape: cube, color: [{', '.join(['1'] * 3000)}], pose: [0, 0, 0, 0, 0, 0]}}\n"),
        f"target: {long}\nobjects:\n" + cube(),
    ]
    for text in cases:
        with pytest.raises(SceneError) as err:
            load_scene(write(tmp_path, text))
        assert len(str(err.value)) < 700, str(err.value)[:200]


def test_allowed_folders_refuse_paths_outside_before_reading(tmp_path, monkeypatch):
    monkeypatch.setenv("ROS_HOME", str(tmp_path / "ros_home"))
    allowed = AllowedFolders.default([tmp_path / "mine"])
    assert user_scene_dir() == tmp_path / "ros_home" / "pg_sim" / "scenes"
    assert user_scene_dir().resolve() in allowed.scenes and (tmp_path / "mine").resolve() in allowed.meshes
    assert allowed.find_scene("packed/case01").name == "case01.yaml"
    outside = write(tmp_path, scene_text(cube()))
    opened = []
    monkeypatch.setattr(Path, "read_text", lambda self, *a, **k: opened.append(self))
    for text in (str(outside), "../../../../etc/passwd", "packed/../../../../../../etc/passwd", "/etc/passwd",
                 "~/../../etc/passwd"):
        with pytest.raises(SceneError, match="outside the allowed scene folders"):
            allowed.find_scene(text)
    assert not opened
    monkeypatch.undo()
    mine = tmp_path / "mine"
    mine.mkdir()
    link = mine / "link.yaml"
    link.symlink_to(outside)  # a link inside pointing outside is outside
    with pytest.raises(SceneError, match="outside the allowed scene folders"):
        allowed.find_scene(str(link))
    inside = write(mine, scene_text(cube()), "inside.yaml")
    assert allowed.find_scene(str(inside)) == inside.resolve()


def test_mesh_paths_outside_the_allowed_folders_are_refused(tmp_path):
    mine = tmp_path / "mine"
    mine.mkdir()
    text = scene_text("  - {shape: mesh, mesh: ../../../../../../../../etc/passwd, color: green,"
                      " pose: [0, 0, 0.02, 0, 0, 0]}\n")
    path = write(mine, text)
    with pytest.raises(SceneError, match="object 0: mesh .*outside the allowed mesh folders"):
        load_scene(path, mesh_folders=[mine])
    with pytest.raises(SceneError, match="object 0"):  # the command line reads any path (a malformed OBJ here)
        load_scene(path)


def test_a_binary_scene_file_is_refused_naming_the_file(tmp_path):
    from pg_sim.scenes.scene import SceneError, load_scene

    bad = tmp_path / "binary.yaml"
    bad.write_bytes(b"\x00\x01\xa4\xff" * 16)
    with pytest.raises(SceneError, match="binary.yaml: not a UTF-8 text file"):
        load_scene(bad)
