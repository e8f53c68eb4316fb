"""VPG / Xu text-case importer: source workspaces, parked rows, target row, target colour, numbered meshes.

Synthetic case files (written to tmp_path) reproduce what the public VPG / Xu et al. cases do: unused objects parked
far outside the workspace (x < -0.85, |y| > 0.4, z = -726), a goal row other than row 0, shared colours, numbered
meshes. The Gazebo centre test uses ../shared/reference (skipped when absent).
"""

from __future__ import annotations

import os
import re
from pathlib import Path

import numpy as np
import pytest

from pg_sim.scenes.colors import PALETTE
from pg_sim.scenes.scene import SceneError, load_scene
from pg_sim.scenes.vpg_frames import SOURCES
from pg_sim.scenes.vpg_import import import_case, import_vpg, main

SHARED = Path(os.environ.get("PG_SHARED") or Path(__file__).resolve().parents[4] / ".." / "shared").resolve()
CASES = SHARED / "reference" / "cases"
CUBE_OBJ = "".join(f"v {x} {y} {z}\n" for x in (0, 0.04) for y in (0, 0.04) for z in (0, 0.04)) + (
    "f 1 2 4 3\nf 5 7 8 6\nf 1 5 6 2\nf 3 4 8 7\nf 1 3 7 5\nf 2 6 8 4\n"
)


def _row(mesh: str, colour: str | tuple[int, int, int], x: float, y: float, z: float = 0.0235,
         angles: tuple[float, float, float] = (0.0, 0.0, 0.3)) -> str:
    rgb = PALETTE[colour] if isinstance(colour, str) else colour
    return " ".join([mesh, *(f"{c / 255:.9f}" for c in rgb), *(f"{v:.6g}" for v in (x, y, z, *angles))])


def _write(tmp_path: Path, rows: list[str], name: str = "case.txt") -> Path:
    path = tmp_path / name
    path.write_text("\n".join(rows) + "\n")
    return path


# VPG's test-10-obj-00 in miniature: rows 1, 3, 4 and 5 are parked by the simulator that wrote the file
PARKED = [
    _row("cube.obj", "green", -0.46, 0.03),  # line 1, row 0: the target
    _row("rect.obj", "blue", -0.87, -0.2),  # line 2, row 1: x beyond -0.85
    _row("cube.obj", "brown", -0.52, -0.05),  # line 3, row 2
    _row("cylinder.obj", "orange", -0.60, -0.41),  # line 4, row 3: |y| > 0.4
    _row("cube.obj", "yellow", -0.55, 0.45),  # line 5, row 4: |y| > 0.4
    _row("triangle.obj", "gray", -0.60, 0.10, -726.58),  # line 6, row 5: fell through the floor
    _row("rect.obj", "red", -0.40, 0.08),  # line 7, row 6
]
FILE_XY = {"cube_0": (-0.46, 0.03), "cube_2": (-0.52, -0.05), "rect_6": (-0.40, 0.08)}


def test_parked_rows_are_left_out_and_the_rest_keep_their_place_in_the_workspace(tmp_path: Path) -> None:
    path = _write(tmp_path, PARKED)
    with pytest.warns(UserWarning, match=r"left out 4 row\(s\) outside the vpg workspace"):
        scene = import_vpg(path)
    assert [o.name for o in scene.objects] == list(FILE_XY)
    for o in scene.objects:  # VPG's workspace centre (-0.5, 0) is `world`
        fx, fy = FILE_XY[o.name]
        assert o.pose[:2] == pytest.approx((fx + 0.5, fy), abs=1e-6), o.name
    target = scene.target_object
    assert target.name == "cube_0" and target.pose[:2] == pytest.approx((0.04, 0.03), abs=1e-6)
    assert max(abs(target.pose[0]), abs(target.pose[1])) < 0.224  # inside our heightmap
    result = import_case(path)
    assert result.workspace == SOURCES["vpg"] and result.scene == scene
    assert [(s.line, s.row, s.mesh) for s in result.skipped] == [
        (2, 1, "rect.obj"), (4, 3, "cylinder.obj"), (5, 4, "cube.obj"), (6, 5, "triangle.obj")]
    reasons = [s.reason for s in result.skipped]
    assert "x -0.870 not in [-0.774, -0.226]" in reasons[0] and "y -0.410 not in [-0.274, 0.274]" in reasons[1]
    assert "y 0.450 not in" in reasons[2] and "z -726.580 not in [-0.050, 0.450]" in reasons[3]
    assert [s.row for s in import_case(path, margin=0.0).skipped] == [1, 3, 4, 5]
    assert [s.row for s in import_case(path, margin=0.2).skipped] == [4, 5]  # x -0.87, y -0.41 within 0.2 m


def test_xu_source_adds_their_loaders_offset_and_a_centre_can_be_given(tmp_path: Path) -> None:
    path = _write(tmp_path, PARKED)
    xu = import_case(path, source="xu")  # their loader places a row at y + 0.1 in VPG's workspace
    assert xu.workspace.centre == (-0.5, -0.1) and [s.row for s in xu.skipped] == [1, 3, 4, 5]
    for o in xu.scene.objects:
        fx, fy = FILE_XY[o.name]
        assert o.pose[:2] == pytest.approx((fx + 0.5, fy + 0.1), abs=1e-6), o.name
    custom = import_case(path, workspace_centre=(-0.5, -0.1))
    assert custom.workspace.name == "custom" and custom.scene == xu.scene
    with pytest.raises(SceneError, match="source 'xu' writes the coppeliasim frame, not 'gazebo'"):
        import_case(path, source="xu", frame="gazebo")
    with pytest.raises(SceneError, match="unknown source 'bullet'"):
        import_case(path, source="bullet")


def test_auto_source_is_decided_by_the_rows_inside_a_workspace(tmp_path: Path) -> None:
    # three rows parked at x = 0.9 (Xu's novel-obj-00 parks one at x 0.31, z -1005) push the mean x past the old
    # importer's Gazebo threshold; only the rows in a workspace vote
    rows = [_row("cube.obj", "green", -0.5, 0.0), _row("rect.obj", "blue", -0.45, 0.05)]
    rows += [_row("cube.obj", c, 0.9, 0.0, -1005.0) for c in ("red", "brown", "gray")]
    result = import_case(_write(tmp_path, rows))
    assert result.workspace.name == "vpg" and len(result.scene.objects) == 2 and len(result.skipped) == 3
    assert result.scene.target_object.pose[:2] == pytest.approx((0.0, 0.0), abs=1e-9)
    gazebo = import_case(_write(tmp_path, [_row("cube.obj", "green", 0.62, 0.041),
                                           _row("cube.obj", "blue", 0.70, -0.05)], "gz.txt"))
    assert gazebo.workspace.name == "gazebo" and not gazebo.skipped  # x and y swapped back, turned: (x, -y)
    assert gazebo.scene.target_object.pose[:2] == pytest.approx((0.62 - 0.655, -(0.041 - 0.007)), abs=1e-6)
    with pytest.raises(SceneError, match="no row lies in a known workspace"):
        import_case(_write(tmp_path, [_row("cube.obj", "green", 2.0, 2.0)], "nowhere.txt"))


def test_rows_centre_is_the_old_bounding_box_centring(tmp_path: Path) -> None:
    path = _write(tmp_path, [_row("cube.obj", "green", -0.46, 0.03), _row("rect.obj", "blue", -0.60, -0.09)])
    rows = import_vpg(path, centre="rows")
    xy = np.array([o.pose[:2] for o in rows.objects])
    assert (xy.min(axis=0) + xy.max(axis=0)) / 2 == pytest.approx((0.0, 0.0), abs=1e-9)
    mapped = np.array([o.pose[:2] for o in import_vpg(path).objects])
    assert xy - xy[0] == pytest.approx(mapped - mapped[0], abs=1e-9)
    with pytest.raises(SceneError, match="unknown centre 'middle'"):
        import_vpg(path, centre="middle")


GOAL = [_row(m, c, -0.5 + 0.05 * i, 0.02 * i) for i, (m, c) in
        enumerate([("cube.obj", "blue"), ("rect.obj", "brown"), ("cylinder.obj", "orange"), ("cube.obj", "green"),
                   ("triangle.obj", "yellow")])]


def test_target_row_picks_the_goal_object(tmp_path: Path) -> None:
    path = _write(tmp_path, ["# Xu et al.: case index - goal object index", "", *GOAL])
    scene = import_vpg(path, target_row=3)
    assert [o.name for o in scene.objects if o.target] == ["cube_3"]
    assert scene.target_object.color == PALETTE["green"] and scene.target == "green"
    assert scene.target_object.pose[:2] == pytest.approx((0.15, 0.06), abs=1e-6)
    other = import_vpg(path, target_row=1)
    assert other.target_object.name == "rect_1" and other.target == "brown"
    assert import_vpg(path).target_object.name == "cube_0"  # default row 0
    out = tmp_path / "goal.yaml"
    assert main([str(path), "--out", str(out), "--target-row", "4"]) == 0
    assert load_scene(out).target_object.name == "triangle_4" and load_scene(out).target == "yellow"


def test_target_row_out_of_range_or_parked_is_a_clear_error(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = _write(tmp_path, ["# comment lines and blank lines are not object rows", "", *GOAL])
    with pytest.raises(SceneError, match=r"target row 5 out of range: the file has 5 object rows \(0-based rows 0-4\)"):
        import_vpg(path, target_row=5)
    with pytest.raises(SceneError, match="target row -1 out of range"):
        import_vpg(path, target_row=-1)
    with pytest.raises(SceneError, match="target row must be an integer"):
        import_vpg(path, target_row=1.0)  # type: ignore[arg-type]
    assert main([str(path), "--out", str(tmp_path / "x.yaml"), "--target-row", "7"]) == 1
    assert "target row 7 out of range" in capsys.readouterr().err
    with pytest.raises(SceneError, match=r"case.txt:2: the target \(row 1, rect.obj\) is parked outside the vpg "
                                         r"workspace \(margin 0.05 m\): x -0.870"):
        import_vpg(_write(tmp_path, PARKED), target_row=1)


def test_a_shared_target_colour_is_refused_naming_both_rows(tmp_path: Path) -> None:
    rows = [_row("cylinder.obj", "green", -0.5, 0.0), _row("cube.obj", "blue", -0.45, 0.05),
            _row("cube.obj", "green", -0.55, -0.05), _row("cube.obj", "green", -0.9, 0.0)]  # the last is parked
    path = _write(tmp_path, rows)
    with pytest.raises(SceneError, match=r"case.txt:3: row 2 \(cube.obj\) has the same colour green as the target, "
                                         r"row 0 \(cylinder.obj, line 1\): the goal would be ambiguous"):
        import_vpg(path)
    scene = import_case(path, target_color="red").scene  # a colour no other object has
    assert scene.target == "red" and scene.target_object.color == PALETTE["red"]
    assert [o.color for o in scene.objects].count(PALETTE["red"]) == 1
    with pytest.raises(SceneError, match=r"case.txt:2: row 1 \(cube.obj\) has the same colour blue as the target, "
                                         r"row 0 \(cylinder.obj, line 1\)"):
        import_vpg(path, target_color="blue")
    with pytest.raises(SceneError, match=r"case.txt:1: row 0 \(cylinder.obj\) has the same colour green as the "
                                         r"target, row 1 \(cube.obj, line 2\).*choose a target colour"):
        import_vpg(path, target_row=1, target_color="green")  # recoloured to a colour two others have
    # a target coloured off the palette is named by the nearest palette colour, which another object has exactly
    off_palette = [_row("cube.obj", (0, 255, 0), -0.5, 0.0), _row("cube.obj", "green", -0.45, 0.05)]
    named = _write(tmp_path, off_palette, "n.txt")
    with pytest.raises(SceneError, match=r"n.txt:2: row 1 \(cube.obj\) has the colour green that names the target"):
        import_vpg(named)


def test_numbered_mesh_rows_stay_meshes_and_parked_ones_need_no_file(tmp_path: Path) -> None:
    meshes = tmp_path / "meshes"
    meshes.mkdir()
    (meshes / "3.obj").write_text(CUBE_OBJ)
    rows = [_row("3.obj", "green", -0.45, 0.05, 0.02), _row("9.obj", "blue", -0.9, 0.0),  # 9.obj: parked, absent
            _row("cube.obj", "brown", -0.5, -0.05)]
    result = import_case(_write(tmp_path, rows), mesh_dir=meshes)
    target = result.scene.target_object
    assert [o.shape for o in result.scene.objects] == ["mesh", "cube"] and target.name == "mesh_0"
    assert target.mesh == str((meshes / "3.obj").resolve()) and target.pose[:2] == pytest.approx((0.05, 0.05))
    assert target.pose[2] >= 0.02 and [(s.row, s.mesh) for s in result.skipped] == [(1, "9.obj")]
    with pytest.raises(SceneError, match=r"case.txt:1: mesh '3.obj' not found in"):
        import_case(tmp_path / "case.txt", mesh_dir=tmp_path)


def test_cli_prints_the_rows_left_out(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = _write(tmp_path, PARKED)
    out = tmp_path / "scene.yaml"
    assert main([str(path), "--out", str(out)]) == 0
    printed = capsys.readouterr().out
    assert "source: vpg workspace x [-0.724, -0.276], y [-0.224, 0.224]" in printed
    assert "skipped line 2 (row 1, rect.obj) at (-0.870, -0.200, 0.024): outside the vpg workspace" in printed
    assert "skipped line 4 (row 3, cylinder.obj)" in printed and "skipped line 5 (row 4, cube.obj)" in printed
    assert "skipped line 6 (row 5, triangle.obj)" in printed and "z -726.580 not in" in printed
    assert "3 objects (4 skipped), target green (cube, row 0)" in printed
    scene = load_scene(out)
    assert [o.name for o in scene.objects] == list(FILE_XY) and scene.target_object.name == "cube_0"
    xu = tmp_path / "xu.yaml"
    assert main([str(path), "--out", str(xu), "--workspace-centre", "-0.5", "-0.1", "--margin", "0.05"]) == 0
    assert load_scene(xu).target_object.pose[:2] == pytest.approx((0.04, 0.13))
    assert main([str(path), "--out", str(xu), "--source", "xu", "--centre", "rows"]) == 0
    assert "(scene centred on its rows)" in capsys.readouterr().out


def test_gazebo_workspace_centre_is_derived_from_the_sdf_copies_of_case_2_to_6() -> None:
    """The mean translation between each CoppeliaSim case 2-6 and its SDF copy (read as a Gazebo-frame file: x and y
    swapped, then turned (x, -y)) plus VPG's centre is the Gazebo workspace centre, to 1 mm."""
    sdf_path = CASES / "gazebo_world.sdf.txt"
    if not sdf_path.is_file():
        pytest.skip(f"reference data: {sdf_path} not available")
    parts = re.split(r"<!--\s*[Cc]ase\s*(\d+)\s*-->", sdf_path.read_text())
    sdf = {int(parts[i]): np.array([[float(v) for v in pose.split()[:2]] for pose in
                                    re.findall(r"<pose>(.*?)</pose>", parts[i + 1])]) for i in range(1, len(parts), 2)}
    offsets = []
    for n in range(2, 7):
        rows = [line.split() for line in (CASES / f"case{n}.txt").read_text().splitlines() if line.strip()]
        coppelia = np.array([[float(r[4]), float(r[5])] for r in rows])
        turned = np.stack([sdf[n][:, 1], -sdf[n][:, 0]], axis=1)  # file (x, y) = SDF (y', x'); turned (x, -y)
        offsets.append(turned.mean(axis=0) - coppelia.mean(axis=0))
    cx, cy = np.mean(offsets, axis=0) + (-0.5, 0.0)
    assert SOURCES["gazebo"].centre == pytest.approx((cx, -cy), abs=1e-3)  # in the file's (unturned) coordinates
    for n in (1, 7, 8, 9, 11, 12, 13, 14):  # every Gazebo-frame case lies well inside that workspace
        result = import_case(CASES / f"case{n}.txt", target_color="green" if n > 10 else None)
        assert result.workspace.name == "gazebo" and not result.skipped
        assert max(max(abs(o.pose[0]), abs(o.pose[1])) for o in result.scene.objects) < 0.16
