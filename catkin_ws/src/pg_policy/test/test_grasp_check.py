"""pg_policy.decision.rules.grasp_check: the jaw-footprint test re-ranks Q_g's best cells without changing the
grasp/push choice."""

import numpy as np
import pytest
from rule_testing import apply_rule, context

from pg_core.geometry import load
from pg_core.heightmap import Heightmap
from pg_policy.decision.rules.grasp_check import JawGraspCheck
from pg_policy.decision.rules.pipeline import RulePipeline

GEO = load()
H = W = 224
C = 112  # the target's centre cell
ALONG_X, ALONG_Y = 0, 4  # rotation indices closing the fingers along x and along y


def _scene(*neighbours: tuple[int, int]) -> tuple[Heightmap, np.ndarray]:
    """A 3 x 3 cm, 3 cm high target at the centre and 3 cm boxes whose centres are (drow, dcol) cells away."""
    height = np.zeros((H, W), np.float32)
    height[C - 7:C + 8, C - 7:C + 8] = 0.03
    target = height > 0
    for dr, dc in neighbours:
        height[C + dr - 7:C + dr + 8, C + dc - 7:C + dc + 8] = 0.03
    hm = Heightmap(np.zeros((H, W, 3), np.uint8), height, np.ones((H, W), bool), GEO.heightmap.resolution,
                   GEO.workspace.bounds)
    return hm, target


def make_grasp_check(variant: str, geometry: object) -> JawGraspCheck:
    return JawGraspCheck.from_arg(geometry, variant)  # type: ignore[arg-type]


def _q() -> np.ndarray:
    q = np.zeros((16, H, W))
    q[ALONG_X, C, C] = 1.0  # the learned favourite: close along x
    q[ALONG_Y, C, C] = 0.5
    return q


def test_a_blocked_favourite_gives_way_to_the_best_free_grasp_at_the_same_value():
    hm, target = _scene((0, 20))  # a neighbour 1 cm beyond the target's +x face: in the sweep of the x-closing jaw
    check = JawGraspCheck(GEO)
    out, res = apply_rule(check, _q(), hm, target, target)
    assert np.unravel_index(np.argmax(out), out.shape) == (ALONG_Y, C, C)
    assert out.max() == 1.0 and out[ALONG_X, C, C] == -np.inf and res.rejected["grasp"] > 0


def test_a_free_favourite_is_kept_unchanged():
    hm, target = _scene()
    check = JawGraspCheck(GEO)
    q = _q()
    out, res = apply_rule(check, q, hm, target, target)
    np.testing.assert_array_equal(out, q)
    assert res.rejected["grasp"] == 0


def test_when_nothing_passes_the_learned_map_is_kept_and_the_check_says_so():
    hm, target = _scene((0, 20), (0, -20), (20, 0), (-20, 0))  # boxed in on all four sides
    q = _q()
    check = JawGraspCheck(GEO)
    out, res = apply_rule(check, q, hm, target, target)
    np.testing.assert_array_equal(out, q)
    assert res.vetoed["grasp"] and not res.push_instead  # "jaw" is not strict: it does not ask for a push
    free, _ = _scene()
    assert not apply_rule(check, q, free, target, target)[1].vetoed["grasp"]
    strict = JawGraspCheck(GEO, strict=True)
    res = apply_rule(strict, q, hm, target, target)[1]
    assert res.push_instead and res.note == JawGraspCheck.veto_note


def test_an_off_centre_cell_fails_even_when_the_jaw_would_be_free():
    hm, target = _scene()
    check = JawGraspCheck(GEO, centre_tol_m=0.004)
    assert check.passes(hm, target, ALONG_X, C, C)
    assert not check.passes(hm, target, ALONG_X, C, C + 5)  # 1 cm off the pad-centred line along x


def test_variants_by_rule_argument():
    assert not make_grasp_check("jaw", GEO).strict and not make_grasp_check("jaw", GEO).vetoes_grasp
    strict = make_grasp_check("jaw-strict", GEO)
    assert strict.strict and strict.vetoes_grasp and strict.spec() == "grasp_check:jaw-strict" and not strict.walls
    walls = make_grasp_check("jaw-walls", GEO)
    assert walls.strict and walls.walls and walls.variant == "jaw-walls"
    assert JawGraspCheck.from_arg(GEO, None).variant == "jaw-walls"  # "grasp_check" alone: the default variant
    with pytest.raises(ValueError, match="unknown grasp check"):
        make_grasp_check("fancy", GEO)


def _lying_half_cylinder() -> tuple[Heightmap, np.ndarray]:
    """A half cylinder (radius 2.2 cm, 4.4 cm long) lying flat side down at the centre, its axis along y."""
    res = GEO.heightmap.resolution
    x = (np.arange(W) - C) * res
    profile = np.sqrt(np.clip(0.022**2 - x**2, 0.0, None))  # height across the axis (m)
    height = np.zeros((H, W), np.float32)
    height[C - 11:C + 11, :] = profile[None, :]
    target = height > 0.001
    hm = Heightmap(np.zeros((H, W, 3), np.uint8), height, np.ones((H, W), bool), res, GEO.workspace.bounds)
    return hm, target


def test_walls_refuse_a_grasp_across_a_curved_profile_and_keep_the_one_along_the_axis():
    hm, target = _lying_half_cylinder()
    walls, footprint = make_grasp_check("jaw-walls", GEO), make_grasp_check("jaw-strict", GEO)
    assert footprint.passes(hm, target, ALONG_X, C, C)  # the footprint alone accepts the squeeze across the curve
    assert not walls.passes(hm, target, ALONG_X, C, C)
    assert walls.passes(hm, target, ALONG_Y, C, C)  # the flat half-disc ends are walls
    out, res = apply_rule(walls, _q(), hm, target, target)
    assert np.unravel_index(np.argmax(out), out.shape) == (ALONG_Y, C, C) and not res.vetoed["grasp"]


def test_walls_accept_a_box_both_ways():
    hm, target = _scene()
    walls = make_grasp_check("jaw-walls", GEO)
    assert walls.passes(hm, target, ALONG_X, C, C) and walls.passes(hm, target, ALONG_Y, C, C)


def _body_with_low_handle() -> tuple[Heightmap, np.ndarray]:
    """A mug lying on its side, as boxes: a body 7 cm across x, 9 cm along y and 7.5 cm high at the centre, and a
    handle lying flat beside it, 1.5 cm high, reaching 3 cm further along +x over 5 cm of the body's length."""
    height = np.zeros((H, W), np.float32)
    height[C - 22:C + 23, C - 17:C + 18] = 0.075
    height[C - 12:C + 13, C + 18:C + 33] = 0.015
    hm = Heightmap(np.zeros((H, W, 3), np.uint8), height, np.ones((H, W), bool), GEO.heightmap.resolution,
                   GEO.workspace.bounds)
    return hm, height > 0


def test_a_low_part_under_the_fingertips_does_not_count_towards_the_width_between_the_pads():
    hm, target = _body_with_low_handle()  # 10 cm across x with the handle: wider than the open jaw (8.5 cm)
    walls = make_grasp_check("jaw-walls", GEO)
    assert walls.passes(hm, target, ALONG_X, C, C)  # fingertips at 3.5 cm pass over the 1.5 cm handle
    assert not walls.passes(hm, target, ALONG_Y, C, C)  # 9 cm along y: too long for the jaw
    flat = Heightmap(hm.color, np.where(target, np.float32(0.075), np.float32(0.0)), hm.valid, hm.resolution,
                     hm.bounds)
    assert not walls.passes(flat, target, ALONG_X, C, C)  # a handle as high as the body is between the pads


@pytest.mark.parametrize("walls", [False, True])
def test_the_batched_check_answers_as_the_one_by_one_check(walls):
    """passes_many (what the re-rank asks, in batches) gives passes' answer for every candidate: free and boxed-in
    targets, every rotation, cells on and off the target."""
    rng = np.random.default_rng(3)
    check = JawGraspCheck(GEO, strict=True, walls=walls)
    answers = []
    for hm, target in (_scene(), _scene((0, 20)), _scene((0, 20), (20, 0)), _scene((0, 20), (0, -20), (20, 0)),
                       _body_with_low_handle()):
        rots, rows, cols = rng.integers(0, 16, 150), rng.integers(C - 9, C + 10, 150), rng.integers(C - 9, C + 10, 150)
        one = [check.passes(hm, target, int(r), int(y), int(x)) for r, y, x in zip(rots, rows, cols, strict=True)]
        many = check.passes_many(hm, target, rots, rows, cols)
        assert many.dtype == bool and many.tolist() == one
        answers += one
    assert 0 < sum(answers) < len(answers)  # both answers occur


def test_a_forced_grasp_falls_back_to_the_best_centred_fit_when_boxed_in():
    """Boxed in on all four sides, no grasp passes; when the push budget forces one, the fallback tests take the
    best candidate on which the target fits between the pads on the pad-centred line (neighbours allowed in the
    sweep) instead of Q_g's argmax, which here sits 1 cm off that line."""
    hm, target = _scene((0, 20), (0, -20), (20, 0), (-20, 0))
    q = np.zeros((16, H, W))
    q[ALONG_X, C, C + 5] = 1.0  # the learned favourite: off the pad-centred line
    q[ALONG_Y, C, C] = 0.5
    check = JawGraspCheck.from_arg(GEO, "jaw-walls")
    pipeline = RulePipeline([check])
    ctx = context(hm, target)
    res = pipeline.apply({"grasp": q, "push": np.zeros_like(q)}, ctx)
    assert res.vetoed["grasp"] and res.push_instead
    out, level = pipeline.forced_grasp(res.q["grasp"], ctx)
    assert level == 1  # the footprint without walls still needs free sweeps; the centred fit passes
    r, row, col = np.unravel_index(np.argmax(out), out.shape)
    assert (row, col) != (C, C + 5) and out.max() == 1.0
    assert check.passes_many(hm, target, np.array([r]), np.array([row]), np.array([col]), walls=False,
                             clearance=False)[0]


def test_a_forced_grasp_without_a_fitting_candidate_keeps_the_map():
    hm, target = _scene((0, 20), (0, -20), (20, 0), (-20, 0))
    q = np.full((16, H, W), -np.inf)
    q[ALONG_X, C, C + 12] = 1.0  # only a cell 2.4 cm off the target's centre is finite: no fit there
    ctx = context(hm, target)
    pipeline = RulePipeline([JawGraspCheck.from_arg(GEO, "jaw-walls")])
    out, level = pipeline.forced_grasp(q, ctx)
    assert level is None and out is q


def _bowl(neighbour: bool = False) -> tuple[Heightmap, np.ndarray]:
    """A 16 cm bowl (wider than the open jaw): a 6 mm thick, 5 cm high wall around a floor 5 mm above the table;
    `neighbour`: a 4 cm high box just outside its +x wall."""
    res = GEO.heightmap.resolution
    rr, cc = np.mgrid[0:H, 0:W]
    r = np.hypot(rr - C, cc - C) * res
    height = np.zeros((H, W), np.float32)
    height[r <= 0.08] = 0.005
    height[(r > 0.074) & (r <= 0.08)] = 0.05
    target = height > 0
    if neighbour:
        height[C - 10:C + 11, C + 42:C + 60] = 0.04
    hm = Heightmap(np.full((H, W, 3), 90, np.uint8), height, np.ones((H, W), bool), res, GEO.workspace.bounds)
    return hm, target


def test_a_bowl_wider_than_the_jaw_passes_as_a_rim_grasp_across_its_wall_only():
    hm, target = _bowl()
    check = JawGraspCheck.from_arg(GEO, "jaw-walls")
    floor_by_wall = C + 25  # 5 cm from the centre: on the floor, 2.4 cm inside the +x wall
    assert check.passes(hm, target, ALONG_X, C, floor_by_wall)  # closing along x: one finger inside the wall
    assert check.passes_many(hm, target, np.array([ALONG_X]), np.array([C]), np.array([floor_by_wall]))[0]
    assert not check.passes(hm, target, ALONG_X, C, C)  # the middle of the floor: no wall within the jaw's reach
    assert not check.passes(hm, target, ALONG_Y, C, floor_by_wall)  # closing along the wall: no pit on that line


def test_a_rim_grasp_with_a_neighbour_in_a_fingers_sweep_is_refused():
    hm, target = _bowl(neighbour=True)
    check = JawGraspCheck.from_arg(GEO, "jaw-walls")
    assert not check.passes(hm, target, ALONG_X, C, C + 25)


@pytest.mark.parametrize("rotation, passes", [(0, True), (1, True), (2, False), (3, False), (7, True)])
def test_a_rim_grasp_must_cross_the_wall_within_the_angle_of_its_normal(rotation, passes):
    """On the bowl's +x side (the wall's normal along x), closing 0 and 22.5 degrees off the normal passes (rotation
    7: 157.5 degrees, the same line as -22.5), 45 and 67.5 degrees off is refused: the pads would meet the wall
    obliquely and it slides out (the probe's finding)."""
    hm, target = _bowl()
    check = JawGraspCheck.from_arg(GEO, "jaw-walls-normal")
    assert check.arg() == "jaw-walls-normal"
    assert JawGraspCheck.from_arg(GEO, "jaw-walls").passes(hm, target, rotation, C, C + 35)  # no angle test there
    row, col = C, C + 35  # on the floor 4 mm inside the +x wall: the line meets it within 7 degrees of the x axis
    assert check.passes(hm, target, rotation, row, col) is passes
    assert bool(check.passes_many(hm, target, np.array([rotation]), np.array([row]), np.array([col]))[0]) is passes


def test_the_wall_normal_points_up_the_wall_and_is_none_on_a_flat_floor():
    from pg_policy.decision.rules.grasp_check import wall_normal

    hm, _ = _bowl()
    normal = wall_normal(hm.height, (C, C + 37), hm.resolution)  # the +x wall's inner face
    assert normal is not None and normal[0] > 0.95
    normal = wall_normal(hm.height, (C - 37, C), hm.resolution)  # the -y wall's inner face (rows along y)
    assert normal is not None and normal[1] < -0.95
    assert wall_normal(hm.height, (C, C), hm.resolution) is None


def test_a_target_wholly_under_the_fingertips_is_not_refused_for_lack_of_cells_above_them():
    """Leaving the low cells out only passes grasps: a flat brick (4 x 3 cm, 1 cm high), all of it lower than the
    fingertips, passes as the whole target does."""
    height = np.zeros((H, W), np.float32)
    height[C - 7:C + 8, C - 10:C + 10] = 0.01
    hm = Heightmap(np.zeros((H, W, 3), np.uint8), height, np.ones((H, W), bool), GEO.heightmap.resolution,
                   GEO.workspace.bounds)
    check = make_grasp_check("jaw", GEO)
    assert check.passes(hm, height > 0, ALONG_X, C, C)
