"""Scene YAML: round trip, validation messages, lookup by name (pg_sim core, no ROS, no PyBullet)."""

from __future__ import annotations

import textwrap
from pathlib import Path

import pytest

from pg_sim.scenes.colors import PALETTE
from pg_sim.scenes.scene import (
    ObjectSpec,
    SceneError,
    SceneSpec,
    find_scene,
    list_scenes,
    load_scene,
    parse_scene,
)
from pg_sim.scenes.scene_writer import save_scene

GOOD = """\
name: demo
target: green
objects:
  - shape: cube
    color: green
    pose: [0.0, 0.0, 0.0225, 0.0, 0.0, 0.3]
  - shape: arch
    size: [0.09, 0.045, 0.045]
    color: [10, 20, 30]
    pose: [0.06, 0.0, 0.0225, 0.0, 0.0, 1.57]
"""


def _write(tmp_path: Path, text: str, name: str = "scene.yaml") -> Path:
    path = tmp_path / name
    path.write_text(textwrap.dedent(text))
    return path


def _obj_block(**fields: str) -> str:
    base = {"shape": "cube", "color": "blue", "pose": "[0, 0, 0.0225, 0, 0, 0]"}
    base.update(fields)
    lines = [f"  - {k}: {v}" if i == 0 else f"    {k}: {v}" for i, (k, v) in enumerate(base.items()) if v != "DROP"]
    return "\n".join(lines) + "\n"


def test_load_marks_the_implicit_target_and_defaults(tmp_path: Path) -> None:
    scene = load_scene(_write(tmp_path, GOOD))
    assert scene.name == "demo" and scene.target == "green" and scene.family == "custom"
    assert scene.target_index == 0 and scene.target_object.color == PALETTE["green"]
    assert scene.objects[0].size is None and scene.objects[0].name == "cube_0"
    assert scene.objects[1].color == (10, 20, 30) and scene.objects[1].size == (0.09, 0.045, 0.045)
    assert scene.objects[0].pose == (0.0, 0.0, 0.0225, 0.0, 0.0, 0.3)


def test_round_trip_save_load_equal(tmp_path: Path) -> None:
    mesh = tmp_path / "meshes" / "thing.obj"
    mesh.parent.mkdir()
    mesh.write_text("v 0 0 0\nv 0.05 0 0\nv 0 0.05 0\nv 0 0 0.05\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n")  # 5 cm
    scene = SceneSpec(
        name="rt",
        target="red",
        family="packed",
        objects=(
            ObjectSpec("cube", None, PALETTE["blue"], (0.1, -0.2, 0.0225, 0.1, 0.2, 0.3), name="a"),
            ObjectSpec("triangle", (0.05, 0.1, 0.04), (255, 87, 87), (0.0, 0.0, 0.02, 0.0, 0.0, -1.2345678901234),
                       target=True, name="t"),
            ObjectSpec("mesh", None, (1, 2, 3), (0.0, 0.1, 0.05, 0.0, 0.0, 0.0), str(mesh.resolve()), name="m",
                       scale=(0.5, 0.5, 0.5)),
            ObjectSpec("mesh", None, (1, 2, 3), (0.0, 0.2, 0.05, 0.0, 0.0, 0.0), str(mesh.resolve()), name="m2",
                       scale=(1.0, 2.0, 3.0)),
        ),
    )
    out = save_scene(scene, tmp_path / "rt.yaml")
    text = out.read_text()
    assert "meshes/thing.obj" in text and str(tmp_path) not in text  # relative to the YAML file
    assert "color: red" in text  # palette colours are written by name
    assert load_scene(out) == scene
    assert save_scene(load_scene(out), tmp_path / "rt2.yaml").read_text() == text


@pytest.mark.parametrize(
    ("objects", "patterns"),
    [
        (_obj_block(shape="blob"), ["object 0", "unknown shape 'blob'", "cube", "half_cylinder", "mesh"]),
        (_obj_block(pose="[0, 0, 0.02]"), ["object 0", "pose", "6 numbers", "got 3"]),
        (_obj_block(pose="[0, 0, 0.02, 0, 0, x]"), ["object 0", "pose", "numbers"]),
        (_obj_block(color="teal"), ["object 0", "unknown colour 'teal'", "green"]),
        (_obj_block(color="[1, 2]"), ["object 0", "3 components"]),
        (_obj_block(color="blue") + _obj_block(color="red"), ["no object has `target: true`", "0 objects"]),
        (_obj_block(color="green") + _obj_block(color="green"), ["2 objects", "objects [0, 1]"]),
        (_obj_block(target="true") + _obj_block(target="true"), ["several targets", "[0, 1]"]),
        (_obj_block(shape="mesh", mesh="no.obj", color="green"), ["object 0", "mesh file not found", "no.obj"]),
        (_obj_block(shape="mesh", color="green"), ["object 0", "needs `mesh:"]),
        (_obj_block(size="[0.1, -0.1, 0.1]", color="green"), ["object 0", "size"]),
        (_obj_block(colour="green"), ["object 0", "unknown key", "colour"]),
        (_obj_block(pose="DROP", color="green"), ["object 0", "missing required key 'pose'"]),
        (_obj_block(name="a", color="green") + _obj_block(name="a"), ["object 1", "duplicate name 'a'"]),
        (_obj_block(target="yes please", color="green"), ["object 0", "target must be true or false"]),
    ],
)
def test_malformed_objects_name_file_object_line_and_problem(tmp_path: Path, objects: str, patterns: list[str]) -> None:
    path = _write(tmp_path, "name: bad\ntarget: green\nobjects:\n" + objects)
    with pytest.raises(SceneError) as err:
        load_scene(path)
    msg = str(err.value)
    assert str(path) in msg
    for pattern in patterns:
        assert pattern in msg, (pattern, msg)


def test_error_messages_carry_the_yaml_line(tmp_path: Path) -> None:
    text = "name: bad\ntarget: green\nobjects:\n" + _obj_block(color="green") + _obj_block(pose="[1, 2]")
    path = _write(tmp_path, text)
    with pytest.raises(SceneError, match=rf"{path}:9: object 1: pose"):  # line 9 holds object 1's pose
        load_scene(path)


def test_yaml_syntax_error_gives_its_line(tmp_path: Path) -> None:
    path = _write(tmp_path, "name: x\nobjects:\n  - shape: cube\n    pose: [0, 0\n    color: green\n")
    with pytest.raises(SceneError, match=rf"{path}:\d+: YAML syntax error"):
        load_scene(path)


def test_top_level_problems(tmp_path: Path) -> None:
    with pytest.raises(SceneError, match="unknown target colour 'chartreuse'"):
        load_scene(_write(tmp_path, GOOD.replace("target: green", "target: chartreuse")))
    with pytest.raises(SceneError, match="`objects` must be a non-empty list"):
        load_scene(_write(tmp_path, "name: empty\nobjects: []\n"))
    with pytest.raises(SceneError, match="a scene must be a mapping"):
        load_scene(_write(tmp_path, "- 1\n- 2\n"))
    with pytest.raises(SceneError, match="unknown key"):
        parse_scene({"name": "x", "objets": []}, "inline")


def test_parse_scene_from_a_mapping_with_an_explicit_target() -> None:
    scene = parse_scene({"name": "m", "target": "red", "objects": [
        {"shape": "rect", "color": "red", "pose": [0, 0, 0.02, 0, 0, 0]},
        {"shape": "cube", "color": "blue", "pose": [0.1, 0, 0.02, 0, 0, 0], "target": True},
    ]}, "inline")
    assert scene.target_index == 1 and scene.target == "red"


def test_find_scene_by_name_and_close_matches(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    root = tmp_path / "scenes"
    (root / "packed").mkdir(parents=True)
    (root / "packed" / "case01.yaml").write_text(GOOD)
    monkeypatch.setenv("PG_SCENE_PATH", str(root))
    assert "packed/case01" in list_scenes()
    assert find_scene("packed/case01") == (root / "packed" / "case01.yaml").resolve()
    assert find_scene("packed/case01.yaml") == find_scene(root / "packed" / "case01.yaml")
    scene = load_scene("packed/case01")
    assert scene.family == "packed"  # from the folder when the file has no `family`
    with pytest.raises(SceneError, match="did you mean: packed/case01"):
        find_scene("packed/case1")


def test_every_shipped_scene_loads() -> None:
    names = list_scenes()
    assert names, "no shipped scenes found (pg_sim/scenes)"
    for name in names:
        scene = load_scene(name)
        assert scene.objects and scene.target_object is not None, name
