"""VPG / Xu / [K] text-case importer. Cases from ../shared/reference (skipped when absent) and synthetic files."""

from __future__ import annotations

import os
import re
from pathlib import Path

import numpy as np
import pybullet as p
import pytest
from scipy.spatial.transform import Rotation

from pg_sim.scenes.objects import spawn_scene
from pg_sim.scenes.scene import SceneError, load_scene
from pg_sim.scenes.vpg_import import import_vpg, main, shape_for_mesh

SHARED = Path(os.environ.get("PG_SHARED") or Path(__file__).resolve().parents[4] / ".." / "shared").resolve()
REFERENCE = SHARED / "reference"
CASES = REFERENCE / "cases"
ALL_CASES = [*range(1, 10), *range(11, 15)]


def _case(n: int) -> Path:
    path = CASES / f"case{n}.txt"
    if not path.is_file():
        pytest.skip(f"reference data: reference case {path} not available")
    return path


def test_case5_shapes_colours_target_and_centring() -> None:
    path = _case(5)
    scene = import_vpg(path, mesh_dir=REFERENCE / "meshes", centre="rows")  # the old bounding-box centring
    assert [o.shape for o in scene.objects] == ["cylinder", "arch", "arch", "rect", "rect"]
    rows = [line.split() for line in path.read_text().splitlines() if line.strip()]
    for obj, row in zip(scene.objects, rows, strict=True):
        assert obj.color == tuple(round(255 * float(c)) for c in row[1:4])
    assert scene.target_index == 0 and scene.target_object.color == (89, 161, 79) and scene.target == "green"
    xy = np.array([o.pose[:2] for o in scene.objects])
    assert (xy.min(axis=0) + xy.max(axis=0)) / 2 == pytest.approx((0.0, 0.0), abs=1e-3)
    assert all(o.pose[2] == pytest.approx(0.0235, abs=1e-4) for o in scene.objects)  # z kept
    assert scene.name == "case5" and scene.family == "packed"
    mapped = import_vpg(path, mesh_dir=REFERENCE / "meshes")  # default: VPG's workspace centre (-0.5, 0) -> world
    for obj, row in zip(mapped.objects, rows, strict=True):
        assert obj.pose[:2] == pytest.approx((float(row[4]) + 0.5, float(row[5])), abs=1e-6)


@pytest.mark.parametrize("n", ALL_CASES)
def test_every_reference_case_imports_and_spawns(n: int) -> None:
    green = "green" if n > 10 else None  # case 14's white milk box shares its colour with the salt
    scene = import_vpg(_case(n), mesh_dir=REFERENCE / "meshes", target_color=green)
    assert scene.target_index == 0 and len(scene.objects) >= 5
    assert scene.family == ("household" if n > 10 else "packed")
    xy = np.array([o.pose[:2] for o in scene.objects])
    assert np.abs(xy).max() < 0.2  # inside the workspace (mapped from the source's)
    rows = import_vpg(_case(n), mesh_dir=REFERENCE / "meshes", target_color=green, centre="rows")
    rxy = np.array([o.pose[:2] for o in rows.objects])
    assert (rxy.min(axis=0) + rxy.max(axis=0)) / 2 == pytest.approx((0.0, 0.0), abs=1e-3)
    assert rxy - rxy[0] == pytest.approx(xy - xy[0], abs=1e-5)  # the same scene, translated
    cid = p.connect(p.DIRECT)
    try:
        bodies = spawn_scene(cid, scene)
        assert len(bodies) == len(scene.objects)
        for body in bodies.values():  # nothing starts below the table
            assert p.getAABB(body, physicsClientId=cid)[0][2] > -1e-3
    finally:
        p.disconnect(cid)


def test_household_case_target_recoloured_green() -> None:
    scene = import_vpg(_case(11), target_color="green")
    assert [o.shape for o in scene.objects] == ["milk_box", "soap", "mug", "mug", "glue", "small_box"]
    assert scene.target == "green" and scene.target_object.color == (89, 161, 79)
    assert all(o.pose[3] == 0 and o.pose[4] == 0 for o in scene.objects)  # household shapes rest upright


def _sdf_cases() -> dict[str, list[tuple[str, list[float]]]]:
    path = CASES / "gazebo_world.sdf.txt"
    if not path.is_file():
        pytest.skip(f"reference data: {path} not available")
    parts = re.split(r"<!--\s*[Cc]ase\s*(\d+)\s*-->", path.read_text())
    out = {}
    for i in range(1, len(parts), 2):
        found = re.findall(r"<uri>model://(\w+)/.*?</uri>\s*<pose>(.*?)</pose>", parts[i + 1])
        out[parts[i]] = [(uri, [float(v) for v in pose.split()]) for uri, pose in found]
    return out


@pytest.mark.parametrize("n", [4, 5, 6])
def test_gazebo_copy_of_a_coppeliasim_case_imports_to_the_same_scene(n: int, tmp_path: Path) -> None:
    """The authors' SDF lists case 2-6 in Gazebo too; written in the text format of their Gazebo cases (x and y
    swapped), they must import to the CoppeliaSim file's scene: this pins both angle conventions and the Gazebo
    model frames."""
    models = {"acube": "cube", "aarch": "concave", "acuboid": "rect", "aatriangle": "triangle", "acylinder": "cylinder"}
    rows = _sdf_cases()[str(n)]
    lines = [f"{models[uri]}.obj 0.5 0.5 0.5 {y} {x} {z} {a} {b} {c}" for uri, (x, y, z, a, b, c) in rows]
    gz_file = tmp_path / f"gazebo{n}.txt"
    gz_file.write_text("\n".join(lines) + "\n")
    # the SDF copies were placed by hand (+-0.03 m from case to case): compare poses relative to the rows' centre
    gazebo = import_vpg(gz_file, target_color="green", centre="rows")
    coppelia = import_vpg(_case(n), centre="rows")
    axes = {"arch": [(0, 1, 0), (0, 0, 1)], "triangle": [(-1, 0, 0), (0, 0, 1)], "rect": [(0, 1, 0), (0, 0, 1)],
            "cylinder": [(0, 0, 1)], "cube": []}
    for obj in coppelia.objects:
        same = [g for g in gazebo.objects if g.shape == obj.shape]
        dist = [np.hypot(g.pose[0] - obj.pose[0], g.pose[1] - obj.pose[1]) for g in same]
        match = same[int(np.argmin(dist))]
        assert min(dist) < 0.015, (obj.name, min(dist))
        r_c, r_g = (Rotation.from_euler("xyz", o.pose[3:]) for o in (obj, match))
        for axis in axes[obj.shape]:
            cos = float(np.dot(r_c.apply(axis), r_g.apply(axis)))
            cos = abs(cos) if obj.shape == "rect" else cos  # a rect is symmetric under half turns
            assert np.degrees(np.arccos(np.clip(cos, -1, 1))) < 5.0, (obj.name, axis)


def test_numbered_meshes_resolve_in_the_mesh_dir(tmp_path: Path) -> None:
    meshes = tmp_path / "meshes"
    meshes.mkdir()
    (meshes / "0.obj").write_text("v 0 0 0\nv 0.04 0 0\nv 0 0.04 0\nv 0 0 0.04\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n")
    case = tmp_path / "case.txt"
    case.write_text("0.obj 0.349 0.631 0.310 -0.5 0.0 0.02 0 0 0\ncube.obj 1 0 0 -0.45 0.05 0.0235 0 0 0.5\n")
    scene = import_vpg(case, mesh_dir=meshes, name="numbered")
    assert [o.shape for o in scene.objects] == ["mesh", "cube"] and scene.name == "numbered"
    assert scene.objects[0].mesh == str((meshes / "0.obj").resolve()) and scene.objects[0].target
    with pytest.raises(SceneError, match=r"case.txt:1: mesh '0.obj' is not one of our shapes; pass a mesh dir"):
        import_vpg(case)
    with pytest.raises(SceneError, match=r"case.txt:1: mesh '0.obj' not found in"):
        import_vpg(case, mesh_dir=tmp_path)


@pytest.mark.parametrize(
    ("text", "pattern"),
    [
        ("cube.obj 1 0 0 0.1 0.2 0.02 0 0\n", r":1: expected 10 fields .* got 9"),
        ("\n# comment\ncube.obj 1 0 0 0.1 zero 0.02 0 0 0\n", r":3: field 'y' is not a number: 'zero'"),
        ("cube.obj 1 0 0 0.1 0.2 0.02 0 0 nan\n", r":1: field 'gamma' is not finite"),
        ("cube.obj 255 0 0 0.1 0.2 0.02 0 0 0\n", r":1: colour components must lie in 0-1"),
        ("\n\n", r"no objects"),
    ],
)
def test_malformed_case_files_name_the_line(tmp_path: Path, text: str, pattern: str) -> None:
    path = tmp_path / "bad.txt"
    path.write_text(text)
    with pytest.raises(SceneError, match=pattern):
        import_vpg(path)


def test_mesh_name_mapping() -> None:
    assert shape_for_mesh("concave.obj") == "arch" and shape_for_mesh("half-cylinder.obj") == "half_cylinder"
    assert shape_for_mesh("milk.obj") == "milk_box" and shape_for_mesh("cup.obj") == "mug"
    assert shape_for_mesh("soap2.obj") == "soap" and shape_for_mesh("z_tuna.obj") == "can"
    assert shape_for_mesh("7.obj") is None


def test_cli_writes_a_loadable_scene(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "out" / "case5.yaml"
    assert main([str(_case(5)), "--mesh-dir", str(REFERENCE / "meshes"), "--out", str(out), "--name", "p5"]) == 0
    assert "wrote" in capsys.readouterr().out
    scene = load_scene(out)
    assert scene == import_vpg(_case(5), name="p5")
    assert main([str(tmp_path / "missing.txt"), "--out", str(out)]) == 1
    assert "not found" in capsys.readouterr().err
