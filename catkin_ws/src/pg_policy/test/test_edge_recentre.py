"""pg_policy.decision.rules.edge_recentre: near the workspace edge the push map's best push carries the target in."""

import math

import numpy as np
import pytest
from rule_testing import apply_rule, context

from pg_core.geometry import load
from pg_core.heightmap import Heightmap, cell_centres, rotation_yaw, world_to_pixel
from pg_policy.decision.rules.edge_recentre import EdgeRecentre
from pg_policy.decision.rules.push_landing import LandingGuard

GEO = load()
H = W = 224
R = GEO.heightmap.rotations
EDGE_X = GEO.workspace.x[1]


def _cell(x: float, y: float) -> tuple[int, int]:
    return world_to_pixel(x, y, GEO.workspace.bounds, GEO.heightmap.resolution)


def _scene(*blocks: tuple[float, float, float]) -> tuple[Heightmap, np.ndarray]:
    """4 x 4 cm blocks 4.5 cm high centred at (x, y) (m); the target is the first. (heightmap, target mask)."""
    height = np.zeros((H, W), np.float32)
    target = np.zeros((H, W), bool)
    for i, (x, y, h) in enumerate(blocks):
        (r0, c0), (r1, c1) = _cell(x - 0.02, y - 0.02), _cell(x + 0.02, y + 0.02)
        height[r0:r1, c0:c1] = h
        if i == 0:
            target[r0:r1, c0:c1] = True
    hm = Heightmap(np.zeros((H, W, 3), np.uint8), height, np.ones((H, W), bool), GEO.heightmap.resolution,
                   GEO.workspace.bounds)
    return hm, target


def _yaw_of(rotation: int) -> float:
    return math.degrees(rotation_yaw(rotation, R)) % 360


def test_a_target_near_the_right_edge_is_pushed_along_minus_x_from_behind_it():
    hm, target = _scene((EDGE_X - 0.06, 0.0, 0.045))
    q = np.random.default_rng(0).uniform(0, 1, (R, H, W)).astype(np.float32)
    out, res = apply_rule(EdgeRecentre(GEO), q, hm, target, np.ones((H, W), bool))
    r, row, col = np.unravel_index(int(np.argmax(out)), out.shape)
    assert _yaw_of(r) == 180.0  # straight back in
    x, y = cell_centres(np.array([row]), np.array([col]), hm.bounds, hm.resolution)[0]
    assert EDGE_X - 0.04 < x < EDGE_X - 0.04 + 0.012 and abs(y) < 0.002  # behind the target, on its centre line
    assert out.max() > q.max() and res.rejected["push"] == 0
    assert LandingGuard(GEO).allows(hm.height, int(r), int(row), int(col))


def test_the_map_is_unchanged_away_from_the_edge_and_while_the_target_is_hidden():
    rule = EdgeRecentre(GEO)
    hm, target = _scene((EDGE_X - 0.1, 0.0, 0.045))  # 10 cm in: farther than NEAR_M
    q = np.random.default_rng(1).uniform(0, 1, (R, H, W)).astype(np.float32)
    assert rule.adjust(q, context(hm, target, np.ones((H, W), bool))) is q
    hm, target = _scene((EDGE_X - 0.06, 0.0, 0.045))
    assert rule.adjust(q, context(hm, target, np.ones((H, W), bool), visible=False)) is q
    assert EdgeRecentre(GEO, near_m=0.03).candidates(context(hm, target, np.ones((H, W), bool))) == []


def test_a_corner_target_is_pushed_along_the_diagonal():
    hm, target = _scene((EDGE_X - 0.06, -EDGE_X + 0.06, 0.045))
    cands = EdgeRecentre(GEO).candidates(context(hm, target, np.ones((H, W), bool)))
    assert cands and _yaw_of(cands[0][0]) == 135.0  # -x, +y


def test_no_push_is_raised_where_the_fingers_would_land_on_an_object_or_off_the_region():
    rule = EdgeRecentre(GEO)
    behind = [(EDGE_X - 0.015, y, 0.045) for y in (-0.04, 0.0, 0.04)]  # a row of blocks between it and the edge
    hm, target = _scene((EDGE_X - 0.06, 0.0, 0.045), *behind)
    assert rule.candidates(context(hm, target, np.ones((H, W), bool))) == []
    hm, target = _scene((EDGE_X - 0.06, 0.0, 0.045))
    assert rule.candidates(context(hm, target, target)) == []  # the push region holds the target only


def test_a_suppressed_cell_stays_suppressed():
    hm, target = _scene((EDGE_X - 0.06, 0.0, 0.045))
    ctx = context(hm, target, np.ones((H, W), bool))
    rule = EdgeRecentre(GEO)
    q = np.zeros((R, H, W), np.float32)
    for c in rule.candidates(ctx):
        q[c] = -np.inf
    assert rule.adjust(q, ctx) is q


def test_the_rule_is_in_the_pipeline_by_name_and_argument():
    from pg_policy.decision.rules.registry import make_pipeline

    pipe = make_pipeline(["edge_recentre:0.05"], GEO)
    assert isinstance(pipe["edge_recentre"], EdgeRecentre) and pipe["edge_recentre"].near == 0.05
    assert pipe.specs() == ["edge_recentre:0.05"]
    with pytest.raises(ValueError, match="edge_recentre"):
        EdgeRecentre.from_arg(GEO, "-1")
