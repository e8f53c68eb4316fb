"""pg_policy.decision.rules.push_landing: pushes whose closed fingers would come down on top of an object give way."""

import numpy as np
import pytest
from rule_testing import apply_rule

from pg_core.geometry import load
from pg_core.heightmap import Heightmap, world_to_pixel
from pg_policy.decision.rules.push_landing import LandingGuard

GEO = load()
H = W = 224
PLUS_X, DIAGONAL = 0, 2  # rotation indices: pushes along +x and along 45 degrees


def _cell(x: float, y: float) -> tuple[int, int]:
    return world_to_pixel(x, y, GEO.workspace.bounds, GEO.heightmap.resolution)


def _block() -> Heightmap:
    """A 4 x 4 cm block, 4.5 cm high, over x, y in [0, 0.04] m."""
    height = np.zeros((H, W), np.float32)
    (r0, c0), (r1, c1) = _cell(0.0, 0.0), _cell(0.04, 0.04)
    height[r0:r1, c0:c1] = 0.045
    return Heightmap(np.zeros((H, W, 3), np.uint8), height, np.ones((H, W), bool), GEO.heightmap.resolution,
                     GEO.workspace.bounds)


def test_the_footprint_is_the_closed_jaw():
    guard = LandingGuard(GEO)
    res = GEO.heightmap.resolution
    area = 2 * GEO.gripper.finger_size[0] * GEO.gripper.finger_size[1] / res**2  # cells under 2 x 1 cm x 2 cm
    for r in (PLUS_X, DIAGONAL):
        assert len(guard.footprints[r]) == pytest.approx(area, rel=0.25)  # cells on the boundary count


def test_cover_is_the_fraction_of_the_jaw_over_the_object():
    guard, hm = LandingGuard(GEO), _block()
    assert guard.cover(hm.height, PLUS_X, *_cell(0.02, 0.02)) == 1.0  # on top of it
    assert guard.cover(hm.height, PLUS_X, *_cell(-0.03, 0.02)) == 0.0  # on the table, 2 cm from its side
    assert 0.1 < guard.cover(hm.height, PLUS_X, *_cell(-0.007, 0.02)) < 0.25  # beside it, over its edge
    assert guard.cover(hm.height, PLUS_X, 0, 0) == 0.0  # the map's corner: cells off the map count as free


def test_a_push_landing_on_an_object_gives_way_to_the_best_push_beside_it():
    guard, hm = LandingGuard(GEO), _block()
    on_top, beside = (PLUS_X, *_cell(0.02, 0.02)), (PLUS_X, *_cell(-0.007, 0.02))
    q = np.zeros((16, H, W))
    q[on_top], q[beside] = 1.0, 0.5
    anywhere = np.ones((H, W), bool)
    out, res = apply_rule(guard, q, hm, anywhere, anywhere)
    assert np.unravel_index(np.argmax(out), out.shape) == beside and out.max() == 1.0
    assert out[on_top] == -np.inf and res.rejected["push"] == 1
    q[on_top], q[beside] = 0.5, 1.0
    out, res = apply_rule(guard, q, hm, anywhere, anywhere)
    np.testing.assert_array_equal(out, q)
    assert res.rejected["push"] == 0


def test_bad_parameters_are_refused():
    with pytest.raises(ValueError, match="landing guard"):
        LandingGuard(GEO, max_cover=1.5)
    with pytest.raises(ValueError, match="landing guard"):
        LandingGuard(GEO, top_k=0)


def test_the_rule_list_takes_the_guard_from_the_options_else_from_the_model_metadata():
    from pg_policy.decision.rules.registry import model_rules
    from pg_policy.policies.options import resolved_rules

    on = {"thresholds": {"push_landing": True}}  # a model exported before rule lists existed
    assert "push_landing" not in model_rules({}) and "push_landing" in model_rules(on)
    assert "push_landing" not in resolved_rules(model_rules(on), {"push_landing": False})
    assert "push_landing" in resolved_rules(model_rules({}), {"push_landing": "on"})
