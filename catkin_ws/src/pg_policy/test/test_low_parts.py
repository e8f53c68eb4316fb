"""pg_policy.decision.rules.low_parts: grasps prefer a thin object's raised parts, and the preference never vetoes."""

import numpy as np
import pytest
from rule_testing import apply_rule, context

from pg_core.geometry import load
from pg_core.heightmap import Heightmap, world_to_pixel
from pg_policy.decision.rules.low_parts import LowParts
from pg_policy.decision.rules.pipeline import RulePipeline
from pg_policy.decision.rules.rule import Rule

GEO = load()
H = W = 224


def _tool(blade_m: float, handle_m: float) -> tuple[Heightmap, np.ndarray, tuple[int, int], tuple[int, int]]:
    """A tool along x at y = 0: a blade (x -0.06 .. 0, `blade_m` high) and a handle (x 0 .. 0.06, `handle_m`
    high), 1 cm wide; with a blade cell and a handle cell."""
    height = np.zeros((H, W), np.float32)
    (r0, c0), (r1, c1), (_, c2) = (world_to_pixel(-0.06, -0.005, GEO.workspace.bounds, GEO.heightmap.resolution),
                                   world_to_pixel(0.0, 0.005, GEO.workspace.bounds, GEO.heightmap.resolution),
                                   world_to_pixel(0.06, 0.0, GEO.workspace.bounds, GEO.heightmap.resolution))
    height[r0:r1, c0:c1] = blade_m
    height[r0:r1, c1:c2] = handle_m
    hm = Heightmap(np.full((H, W, 3), 90, np.uint8), height, np.ones((H, W), bool), GEO.heightmap.resolution,
                   GEO.workspace.bounds)
    row = (r0 + r1) // 2
    return hm, height > 0, (row, (c0 + c1) // 2), (row, (c1 + c2) // 2)


def _q(best: tuple[int, int, int], second: tuple[int, int, int]) -> np.ndarray:
    q = np.zeros((16, H, W))
    q[best], q[second] = 0.9, 0.6
    return q


def test_the_best_grasp_on_a_blade_gives_way_to_the_best_on_the_handle_with_the_best_value():
    hm, target, blade, handle = _tool(0.003, 0.008)
    q = _q((4, *blade), (4, *handle))
    out, res = apply_rule(LowParts(GEO), q, hm, target)
    assert np.unravel_index(np.argmax(np.where(target[None], out, -np.inf)), out.shape) == (4, *handle)
    assert out[(4, *handle)] == pytest.approx(0.9) and res.rejected["grasp"] >= 1 and not res.vetoed["grasp"]


def test_a_target_low_everywhere_keeps_its_map_and_is_never_vetoed():
    hm, target, blade, handle = _tool(0.003, 0.003)
    q = _q((4, *blade), (4, *handle))
    out, res = apply_rule(LowParts(GEO), q, hm, target)
    np.testing.assert_array_equal(out, q)
    assert not res.vetoed["grasp"] and not res.push_instead


class _NoHandle(Rule):
    """A vetoing check that refuses every grasp on the handle's half (x > 0)."""

    name, kind, primitive, vetoes_grasp, veto_note = "no_handle", "check", "grasp", True, "no handle"

    def __init__(self, col: int) -> None:
        self.col = col

    def candidate_test(self, ctx):
        return lambda r, row, col: col < self.col


def test_when_the_checks_refuse_every_raised_cell_the_preference_is_dropped_not_the_grasp():
    hm, target, blade, handle = _tool(0.003, 0.008)
    q = _q((4, *handle), (4, *blade))  # the handle is best, but the check refuses it
    pipe = RulePipeline([LowParts(GEO), _NoHandle(handle[1] - 20)])
    res = pipe.apply({"grasp": q, "push": np.zeros_like(q)}, context(hm, target))
    out = res.q["grasp"]
    assert np.unravel_index(np.argmax(np.where(target[None], out, -np.inf)), out.shape) == (4, *blade)
    assert not res.vetoed["grasp"] and not res.push_instead
    forced, level = pipe.forced_grasp(q, context(hm, target))
    assert level is None  # no rule here has fallbacks: the forced grasp keeps the map


def test_arguments_and_spec():
    assert LowParts.from_arg(GEO, None).spec() == "low_parts"
    assert LowParts.from_arg(GEO, "0.004").spec() == "low_parts:0.004"
    with pytest.raises(ValueError, match="least height"):
        LowParts.from_arg(GEO, "tall")
    with pytest.raises(ValueError, match="low_parts needs"):
        LowParts(GEO, min_height_m=-0.001)
