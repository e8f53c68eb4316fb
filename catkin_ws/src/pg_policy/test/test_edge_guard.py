"""pg_policy.decision.rules.edge_guard: pushes that would carry the target out of the workspace give way to the best
other push."""

import math

import numpy as np
import pytest
from rule_testing import apply_rule, context

from pg_core.geometry import load
from pg_core.heightmap import Heightmap, world_to_pixel
from pg_policy.decision.rules.edge_guard import EdgeGuard
from pg_policy.decision.rules.pipeline import RulePipeline

GEO = load()
H = W = 224
PLUS_X, PLUS_Y, MINUS_Y = 0, 4, 12  # rotation indices: pushes along +x, +y and -y


def _target_at(x: float, y: float) -> tuple[Heightmap, np.ndarray]:
    """A 3 x 3 cm target centred at (x, y) m."""
    height = np.zeros((H, W), np.float32)
    r, c = world_to_pixel(x, y, GEO.workspace.bounds, GEO.heightmap.resolution)
    height[r - 7:r + 8, c - 7:c + 8] = 0.03
    hm = Heightmap(np.zeros((H, W, 3), np.uint8), height, np.ones((H, W), bool), GEO.heightmap.resolution,
                   GEO.workspace.bounds)
    return hm, height > 0


def _q(favourite: tuple[int, int, int], second: tuple[int, int, int]) -> np.ndarray:
    q = np.zeros((16, H, W))
    q[favourite] = 1.0
    q[second] = 0.5
    return q


def _cell(x: float, y: float) -> tuple[int, int]:
    return world_to_pixel(x, y, GEO.workspace.bounds, GEO.heightmap.resolution)


def test_a_push_towards_the_edge_gives_way_to_the_best_push_that_keeps_the_target_inside():
    hm, target = _target_at(0.0, -0.15)  # 4.4 cm inside the 3 cm margin; a full push along -y ends outside
    favourite, second = (MINUS_Y, *_cell(0.0, -0.12)), (PLUS_Y, *_cell(0.0, -0.18))
    guard = EdgeGuard(GEO)
    out, res = apply_rule(guard, _q(favourite, second), hm, target, np.ones((H, W), bool))
    assert np.unravel_index(np.argmax(out), out.shape) == second and out.max() == 1.0
    assert out[favourite] == -np.inf and res.rejected["push"] == 1


def test_pushes_in_the_middle_or_along_the_edge_or_missing_the_target_are_kept():
    guard = EdgeGuard.from_arg(GEO, "0")  # along the edge too: no inward distance asked
    for (x, y), favourite in (((0.0, 0.0), (MINUS_Y, *_cell(0.0, 0.03))),  # middle: ends at y -0.1, inside
                              ((0.0, -0.2), (PLUS_X, *_cell(-0.03, -0.2))),  # along the edge: no farther out
                              ((0.0, -0.15), (MINUS_Y, *_cell(0.06, -0.12)))):  # misses the target
        hm, target = _target_at(x, y)
        q = _q(favourite, (PLUS_Y, 0, 0))
        out, res = apply_rule(guard, q, hm, target, np.ones((H, W), bool))
        np.testing.assert_array_equal(out, q)
        assert res.rejected["push"] == 0


def test_with_an_inward_distance_a_target_beyond_the_margin_must_be_carried_back_inwards():
    # the target at y -0.2 lies 6 mm beyond the shrunk workspace: a push along the edge that meets it no longer
    # passes; a push carrying it 1 cm or more back in does, and so does a push that misses it
    guard = EdgeGuard(GEO)  # INWARD_M = 0.01
    assert guard.spec() == "edge_guard" and EdgeGuard.from_arg(GEO, "0.01").spec() == "edge_guard"
    assert EdgeGuard.from_arg(GEO, "0").spec() == "edge_guard:0"
    hm, target = _target_at(0.0, -0.2)
    along = (PLUS_X, *_cell(-0.03, -0.2))
    out, res = apply_rule(guard, _q(along, (PLUS_Y, *_cell(0.0, -0.22))), hm, target, np.ones((H, W), bool))
    assert out[along] == -np.inf and res.rejected["push"] >= 1
    for kept in ((PLUS_Y, *_cell(0.0, -0.22)), (MINUS_Y, *_cell(0.06, -0.12))):  # inwards; missing the target
        q = _q(kept, (PLUS_X, 0, 0))
        np.testing.assert_array_equal(apply_rule(guard, q, hm, target, np.ones((H, W), bool))[0], q)
    with pytest.raises(ValueError, match="inward distance"):
        EdgeGuard.from_arg(GEO, "far")
    with pytest.raises(ValueError, match="inward distance must be >= 0"):
        EdgeGuard.from_arg(GEO, "-0.01")


def test_with_a_near_distance_a_target_near_a_side_must_be_carried_back_inwards():
    # the target at y -0.17 lies 5.4 cm from the side, inside the 3 cm margin but within 8 cm of the side: with
    # "0.01:0.08" a push along the side that meets it no longer passes, one carrying it 1 cm or more back in does,
    # and so do a push that misses it and any push of a target farther from the sides
    guard = EdgeGuard.from_arg(GEO, "0.01:0.08")
    assert guard.spec() == "edge_guard:0.01:0.08" and EdgeGuard.from_arg(GEO, "0.02").near == 0.0
    hm, target = _target_at(0.0, -0.17)
    along = (PLUS_X, *_cell(-0.03, -0.17))
    q = _q(along, (PLUS_Y, *_cell(0.0, -0.19)))
    np.testing.assert_array_equal(apply_rule(EdgeGuard(GEO), q, hm, target, np.ones((H, W), bool))[0], q)
    out, res = apply_rule(guard, q, hm, target, np.ones((H, W), bool))
    assert out[along] == -np.inf and res.rejected["push"] >= 1
    for kept in ((PLUS_Y, *_cell(0.0, -0.19)), (MINUS_Y, *_cell(0.06, -0.12))):  # inwards; missing the target
        q = _q(kept, (PLUS_X, 0, 0))
        np.testing.assert_array_equal(apply_rule(guard, q, hm, target, np.ones((H, W), bool))[0], q)
    hm, target = _target_at(0.0, -0.1)  # 12.4 cm from the side
    q = _q((PLUS_X, *_cell(-0.03, -0.1)), (PLUS_Y, 0, 0))
    np.testing.assert_array_equal(apply_rule(guard, q, hm, target, np.ones((H, W), bool))[0], q)
    with pytest.raises(ValueError, match="near distance must be >= 0"):
        EdgeGuard.from_arg(GEO, "0.01:-0.08")


def _with_block(hm: Heightmap, x0: float, x1: float, y0: float, y1: float) -> Heightmap:
    """`hm` with a 3 cm high block over [x0, x1] x [y0, y1] m added."""
    height = hm.height.copy()
    (r0, c0), (r1, c1) = _cell(x0, y0), _cell(x1, y1)
    height[min(r0, r1):max(r0, r1) + 1, min(c0, c1):max(c0, c1) + 1] = 0.03
    return Heightmap(hm.color, height, hm.valid, hm.resolution, hm.bounds)


def test_a_push_into_a_neighbour_touching_the_target_carries_the_target_with_it():
    hm, target = _target_at(0.0, -0.15)  # the target spans y -0.165 .. -0.135
    touching = _with_block(hm, -0.015, 0.015, -0.133, -0.06)  # a neighbour on the target's +y side, 1 cell apart
    apart = _with_block(hm, -0.015, 0.015, -0.121, -0.06)  # the same neighbour 6 cells (12 mm) away
    # along -y from y = +0.002 the fingers stop 0.007 short of the target but meet the neighbour after 0.06
    favourite, second = (MINUS_Y, *_cell(0.0, 0.002)), (PLUS_Y, *_cell(0.0, -0.18))
    guard = EdgeGuard(GEO)
    assert apply_rule(guard, _q(favourite, second), touching, target, np.ones((H, W), bool))[0][favourite] == -np.inf
    q = _q(favourite, second)
    np.testing.assert_array_equal(apply_rule(guard, q, apart, target, np.ones((H, W), bool))[0], q)
    cluster = guard.cluster(touching.height, target)
    assert cluster[target].all() and cluster.sum() > target.sum()
    assert guard.cluster(apart.height, target).sum() == target.sum()


def test_carried_distance_is_the_push_left_after_contact():
    guard = EdgeGuard(GEO)
    t_xy = np.array([[0.05, 0.0], [0.06, 0.0]])
    assert guard.carried(t_xy, np.zeros(2), 0.0) == pytest.approx(GEO.primitives.push_length - 0.05)
    assert guard.carried(t_xy, np.zeros(2), math.pi / 2) == 0.0  # the corridor along +y misses it
    assert guard.outside(np.zeros(2)) == 0.0 and guard.outside(np.array([0.0, -0.224])) == pytest.approx(0.03)


def test_bad_parameters_are_refused():
    with pytest.raises(ValueError, match="edge guard"):
        EdgeGuard(GEO, margin_m=-0.01)
    with pytest.raises(ValueError, match="edge guard"):
        EdgeGuard(GEO, gap_cells=-1)


def test_the_rule_list_takes_the_guard_from_the_options_else_from_the_model_metadata():
    from pg_policy.decision.rules.registry import model_rules
    from pg_policy.policies.options import resolved_rules

    on = {"thresholds": {"edge_guard": True}}  # a model exported before rule lists existed
    assert "edge_guard" not in model_rules({}) and "edge_guard" in model_rules(on)
    assert "edge_guard" not in resolved_rules(model_rules(on), {"edge_guard": "off"})
    assert "edge_guard" in resolved_rules(model_rules({}), {"edge_guard": True})


def test_while_the_target_is_hidden_a_push_must_not_carry_the_object_it_meets_out():
    hm, _ = _target_at(0.0, -0.15)  # a block the hidden target may lie under, 4.4 cm inside the margin
    hidden = np.zeros((H, W), bool)  # the goal: every object cell stands in for the target (RuleContext)
    guard = EdgeGuard(GEO)
    out_push, in_push = (MINUS_Y, *_cell(0.0, -0.12)), (PLUS_Y, *_cell(0.0, -0.18))
    res = RulePipeline([guard]).apply({"push": _q(out_push, in_push), "grasp": np.zeros((16, H, W))},
                                      context(hm, hm.height > 0, np.ones((H, W), bool), visible=False))
    assert res.q["push"][out_push] == -np.inf and res.rejected["push"] == 1
    assert np.unravel_index(np.argmax(res.q["push"]), res.q["push"].shape) == in_push
    test = guard.candidate_test(context(hm, hidden, visible=False))
    assert test is not None and test(MINUS_Y, *_cell(0.06, -0.12))  # misses the block
    assert test(PLUS_X, *_cell(-0.05, -0.15))  # along the edge, no farther out
    empty = Heightmap(hm.color, np.zeros((H, W), np.float32), hm.valid, hm.resolution, hm.bounds)
    assert guard.candidate_test(context(empty, hidden, visible=False)) is None
