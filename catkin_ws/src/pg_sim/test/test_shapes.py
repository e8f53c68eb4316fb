"""Shapes, colours and spawning (pg_sim core, PyBullet DIRECT, no ROS)."""

from __future__ import annotations

import math
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pybullet as p
import pytest

from pg_sim.scenes import meshes, shapes
from pg_sim.scenes.colors import COLORS, PALETTE, color_name, nearest_color_name, resolve_color
from pg_sim.scenes.objects import build_shape, object_pose, spawn_object
from pg_sim.scenes.scene import ObjectSpec

BLOCKS = ("cube", "rect", "triangle", "arch", "cylinder", "half_cube", "half_cylinder")
NOMINAL = {  # DESIGN.md section 6, metres
    "cube": (0.045, 0.045, 0.045),
    "rect": (0.045, 0.09, 0.045),
    "triangle": (0.045, 0.09, 0.045),
    "arch": (0.09, 0.045, 0.045),
    "cylinder": (0.044, 0.044, 0.045),
    "half_cube": (0.0225, 0.045, 0.045),
    "half_cylinder": (0.044, 0.022, 0.045),
}


@pytest.fixture()
def client() -> Iterator[int]:
    cid = p.connect(p.DIRECT)
    p.setGravity(0, 0, -9.81, physicsClientId=cid)
    yield cid
    p.disconnect(cid)


@pytest.fixture(autouse=True)
def _cache(tmp_path_factory: pytest.TempPathFactory, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("PUSHGRASP_CACHE", str(tmp_path_factory.getbasetemp() / "cache"))


def _plane(cid: int) -> int:
    return p.createMultiBody(0, p.createCollisionShape(p.GEOM_PLANE, physicsClientId=cid), physicsClientId=cid)


def _spec(shape: str, pose=(0, 0, 0.5, 0, 0, 0), size=None) -> ObjectSpec:
    return ObjectSpec(shape, size, COLORS["blue"], tuple(float(v) for v in pose), name=shape)


def _spawn(cid: int, shape: str, pose=(0, 0, 0.5, 0, 0, 0), size=None) -> int:
    return spawn_object(cid, _spec(shape, pose, size))


def _pieces(cid: int, spec: ObjectSpec) -> int:
    """Collision pieces of the shape `spec` spawns with. Objects are maximal-coordinate bodies, whose shapes PyBullet
    does not report: the same collision shape is inspected on a reduced-coordinate body made for the purpose."""
    col, _, _ = build_shape(cid, spec)
    probe = p.createMultiBody(0.0, col, physicsClientId=cid)
    n = len(p.getCollisionShapeData(probe, -1, physicsClientId=cid))
    p.removeBody(probe, physicsClientId=cid)
    return n


def _settle(cid: int, steps: int = 480) -> None:
    for _ in range(steps):
        p.stepSimulation(physicsClientId=cid)


def _ray(cid: int, start, end) -> tuple[float, float, float] | None:
    hit = p.rayTest(start, end, physicsClientId=cid)[0]
    return hit[3] if hit[0] >= 0 else None


def test_registry_is_a_dict_of_builders_with_the_design_sizes() -> None:
    for name in BLOCKS:
        assert shapes.REGISTRY[name].default_size == pytest.approx(NOMINAL[name])
    for name, builder in shapes.REGISTRY.items():
        assert builder.extents() == pytest.approx(builder.default_size, abs=1e-9), name
        assert 0.05 <= builder.default_mass <= 0.3, name
        if builder.household:
            assert min(builder.default_size[:2]) <= 0.085, f"{name} not graspable by a 0.085 m gripper"


@pytest.mark.parametrize("name", sorted(shapes.REGISTRY))
def test_every_shape_spawns_with_its_nominal_aabb(client: int, name: str) -> None:
    p.setGravity(0, 0, 0, physicsClientId=client)
    builder = shapes.REGISTRY[name]
    body = _spawn(client, name)
    lo, hi = (np.asarray(v) for v in p.getAABB(body, physicsClientId=client))
    half = np.asarray(builder.default_size) / 2
    centre = np.array([0, 0, 0.5])
    if not builder.uses_hulls:  # primitives: exact
        assert np.abs(hi - centre - half).max() <= 1e-3 and np.abs(lo - centre + half).max() <= 1e-3, (hi, lo)
        return
    # Convex-hull parts: Bullet pads their AABB by HULL_MARGIN beyond the physical (nominal) faces, and its margin
    # rounds sharp corners (the triangle's 45 deg corners end 1.4 mm short of the sharp tip along y).
    pad = shapes.HULL_MARGIN
    for side in (hi - centre, centre - lo):
        assert np.all(side <= half + pad + 1e-6), (name, side, half)
        assert np.all(side >= half + pad - 1e-3) or name == "triangle", (name, side, half)
        assert np.all(side >= half - 1.5e-3), (name, side, half)


@pytest.mark.parametrize("name", sorted(shapes.REGISTRY))
def test_every_shape_rests_on_its_nominal_height(client: int, name: str) -> None:
    _plane(client)
    size = shapes.REGISTRY[name].default_size
    body = _spawn(client, name, (0, 0, size[2] / 2 + 0.002, 0, 0, 0))
    _settle(client)
    assert object_pose(client, body)[2] == pytest.approx(size[2] / 2, abs=1e-3)


def test_arch_is_a_compound_with_its_notch_at_plus_y(client: int) -> None:
    _spawn(client, "arch", (0, 0, 0, 0, 0, 0))
    assert _pieces(client, _spec("arch")) > 1
    # Ray along -y through the middle enters the notch: first hit at the notch bottom (y = 0.0225 - 0.0235).
    hit = _ray(client, (0, 0.2, 0), (0, -0.2, 0))
    assert hit is not None and hit[1] == pytest.approx(-0.001, abs=1.5e-3)
    hit = _ray(client, (0.035, 0.2, 0), (0.035, -0.2, 0))  # through a leg: the full block face
    assert hit is not None and hit[1] == pytest.approx(0.0225, abs=1.5e-3)
    hit = _ray(client, (0, -0.2, 0), (0, 0.2, 0))  # the back face (-y) is flat
    assert hit is not None and hit[1] == pytest.approx(-0.0225, abs=1.5e-3)


@pytest.mark.parametrize("cube_size", [0.045, 0.03])
def test_cube_dropped_into_the_arch_notch_rests_below_the_arch_top(client: int, cube_size: float) -> None:
    _plane(client)
    arch = _spawn(client, "arch", (0, 0, 0.0225 + 1e-4, math.pi / 2, 0, 0))  # roll +90 deg: notch opens upwards
    _settle(client, 120)
    arch_top = p.getAABB(arch, physicsClientId=client)[1][2] - shapes.HULL_MARGIN
    assert arch_top == pytest.approx(0.045, abs=1.5e-3)
    cube = _spawn(client, "cube", (0, 0, 0.12, 0, 0, 0), size=(cube_size,) * 3)
    _settle(client, 960)
    cube_bottom = object_pose(client, cube)[2] - cube_size / 2
    assert cube_bottom < arch_top - (0.004 if cube_size > 0.04 else 0.012), (cube_bottom, arch_top)
    assert abs(object_pose(client, cube)[0]) < 0.01  # stayed in the notch


def test_half_cylinder_flat_side_faces_plus_y_and_triangle_apex_minus_x(client: int) -> None:
    _spawn(client, "half_cylinder", (0, 0, 0, 0, 0, 0))
    for x in (-0.015, 0.0, 0.015):
        hit = _ray(client, (x, 0.2, 0), (x, -0.2, 0))
        assert hit is not None and hit[1] == pytest.approx(0.011, abs=1.5e-3)  # flat face at +y
    hit = _ray(client, (0.015, -0.2, 0), (0.015, 0.2, 0))
    assert hit is not None and hit[1] > -0.011 + 0.003  # curved side: not a flat face at -y there
    p.resetSimulation(physicsClientId=client)
    _spawn(client, "triangle", (0, 0, 0, 0, 0, 0))
    near_apex = _ray(client, (-0.0175, 0.2, 0), (-0.0175, -0.2, 0))
    near_base = _ray(client, (0.0175, 0.2, 0), (0.0175, -0.2, 0))
    assert near_apex is not None and near_apex[1] == pytest.approx(0.005, abs=1.5e-3)
    assert near_base is not None and near_base[1] == pytest.approx(0.040, abs=1.5e-3)


def test_mug_is_hollow(client: int) -> None:
    _spawn(client, "mug", (0, 0, 0, 0, 0, 0))
    assert _pieces(client, _spec("mug")) > 1
    size = shapes.REGISTRY["mug"].default_size
    cx = -size[0] / 2 + size[1] / 2  # body axis (the handle is at +x)
    hit = _ray(client, (cx, 0, 0.3), (cx, 0, -0.3))
    assert hit is not None and hit[2] < -size[2] / 2 + 0.01  # straight down the opening onto the bottom


def test_spawn_object_pose_colour_and_friction(client: int) -> None:
    pose = (0.1, -0.05, 0.3, 0.2, -0.1, 1.0)
    body = spawn_object(client, ObjectSpec("rect", None, resolve_color("red"), pose, name="r"))
    assert object_pose(client, body) == pytest.approx(pose, abs=1e-6)
    rgba = p.getVisualShapeData(body, physicsClientId=client)[0][7]
    assert rgba == pytest.approx((1.0, 87 / 255, 87 / 255, 1.0), abs=1e-3)
    dyn = p.getDynamicsInfo(body, -1, physicsClientId=client)
    assert dyn[0] == pytest.approx(shapes.REGISTRY["rect"].default_mass) and 0.5 <= dyn[1] <= 1.0 and dyn[5] == 0.0


def test_unknown_shape_and_bad_size_are_clear_errors(client: int) -> None:
    with pytest.raises(ValueError, match="unknown shape 'blob'.*cube"):
        _spawn(client, "blob")
    with pytest.raises(ValueError, match="size must be 3 positive"):
        _spawn(client, "cube", size=(0.1, 0.1))


def _write_prism_obj(path: Path, poly: list[tuple[float, float]], h: float, tris: list[tuple[int, int, int]]) -> None:
    """Closed prism; ``tris`` triangulates the (possibly concave) counter-clockwise cap polygon."""
    n = len(poly)
    lines = [f"v {x} {y} {z}" for z in (-h, h) for x, y in poly]
    lines += [f"f {a + 1} {c + 1} {b + 1}" for a, b, c in tris]  # bottom, facing -z
    lines += [f"f {n + a + 1} {n + b + 1} {n + c + 1}" for a, b, c in tris]
    lines += [f"f {i + 1} {(i + 1) % n + 1} {n + (i + 1) % n + 1} {n + i + 1}" for i in range(n)]
    path.write_text("\n".join(lines) + "\n")


def test_mesh_shape_convex_loads_directly_concave_is_decomposed_once(client: int, tmp_path: Path) -> None:
    box = tmp_path / "box.obj"
    _write_prism_obj(box, [(0, 0), (0.04, 0), (0.04, 0.02), (0, 0.02)], 0.01, [(0, 1, 2), (0, 2, 3)])
    mesh = meshes.load_obj(box)
    assert meshes.mesh_volume(mesh) == pytest.approx(0.04 * 0.02 * 0.02) and meshes.is_convex(mesh)
    body = spawn_object(client, ObjectSpec("mesh", None, (1, 2, 3), (0, 0.5, 0, 0, 0, 0), str(box), scale=(2, 2, 2)))
    lo, hi = p.getAABB(body, physicsClientId=client)
    pad = 4 * shapes.HULL_MARGIN  # meshes are used as given: Bullet adds its margin, the AABB twice that per side
    assert np.subtract(hi, lo) == pytest.approx((0.08 + pad, 0.04 + pad, 0.04 + pad), abs=1e-3)
    assert len(list(shapes.cache_dir("vhacd").glob("*.obj"))) == 0
    ell = tmp_path / "ell.obj"  # L-shaped prism: 3/4 of its hull area
    poly = [(0, 0), (0.06, 0), (0.06, 0.03), (0.03, 0.03), (0.03, 0.06), (0, 0.06)]
    _write_prism_obj(ell, poly, 0.015, [(3, 4, 5), (3, 5, 0), (3, 0, 1), (3, 1, 2)])
    assert not meshes.is_convex(meshes.load_obj(ell))
    ell_spec = ObjectSpec("mesh", None, (1, 2, 3), (0, 0, 0, 0, 0, 0), str(ell))
    spawn_object(client, ell_spec)
    assert _pieces(client, ell_spec) > 1
    cached = list(shapes.cache_dir("vhacd").glob("*.obj"))
    assert len(cached) == 1
    stamp = cached[0].stat().st_mtime_ns
    spawn_object(client, ObjectSpec("mesh", None, (1, 2, 3), (0.2, 0, 0, 0, 0, 0), str(ell)))
    assert cached[0].stat().st_mtime_ns == stamp  # reused, not recomputed
    assert _ray(client, (0.015, 0.015, 0.3), (0.015, 0.015, -0.3)) is None  # the notch of the L stays empty
    with pytest.raises(FileNotFoundError):
        spawn_object(client, ObjectSpec("mesh", None, (1, 2, 3), (0, 0, 0, 0, 0, 0), str(tmp_path / "none.obj")))


def test_decomposition_keeps_vhacd_output_off_stdout(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                                     capfd: pytest.CaptureFixture[str]) -> None:
    monkeypatch.setenv("PUSHGRASP_CACHE", str(tmp_path / "own-cache"))  # decomposed here, not reused
    ell = tmp_path / "ell.obj"
    poly = [(0, 0), (0.06, 0), (0.06, 0.03), (0.03, 0.03), (0.03, 0.06), (0, 0.06)]
    _write_prism_obj(ell, poly, 0.015, [(3, 4, 5), (3, 5, 0), (3, 0, 1), (3, 1, 2)])
    capfd.readouterr()
    out = meshes.decomposed_obj(ell)
    print("after")
    captured = capfd.readouterr()
    assert out.exists() and "V-HACD" not in captured.out and captured.out == "after\n"
    assert list(out.parent.glob(".*.log")) == []  # its log goes with the temporary files


def test_colours() -> None:
    assert resolve_color("green") == (89, 161, 79) == PALETTE["green"]
    assert resolve_color("Grey") == COLORS["gray"] and resolve_color([1, 2, 3]) == (1, 2, 3)
    assert len(COLORS) == 10 and color_name((89, 161, 79)) == "green" and color_name((1, 2, 3)) is None
    assert nearest_color_name((0, 255, 0)) == "green"
    for bad, msg in (("teal", "unknown colour 'teal'.*green"), ([1, 2], "3 components"), ([0, 0, 256], "0-255"),
                     ([0.5, 0, 0], "integers"), (7, "name or")):
        with pytest.raises(ValueError, match=msg):
            resolve_color(bad)  # type: ignore[arg-type]
