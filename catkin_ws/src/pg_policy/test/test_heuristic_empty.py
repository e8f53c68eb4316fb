"""The heuristic planner on target masks whose selections can come out empty (the novel-object crash
"ValueError: zero-size array to reduction operation minimum" in the push rule): a target in pieces far apart, a
window holding no target cell, an empty mask, a target of a few cells, one boxed in, one at the border."""

from __future__ import annotations

import math

import numpy as np
import pytest

from pg_core.geometry import load
from pg_core.heightmap import Heightmap, world_to_pixel
from pg_core.palette import PALETTE
from pg_core.target_mask import target_mask
from pg_policy.decision.jaw_fit import CellWindow
from pg_policy.policies.heuristic_planner import HeuristicParams, HeuristicPlanner
from pg_policy.policies.registry import make_policy

G = load()
BOUNDS, RES, N = G.workspace.bounds, G.heightmap.resolution, G.heightmap.rows
CUBE = 0.045


class _Obs:
    def __init__(self, hm: Heightmap, target: str = "green") -> None:
        self.heightmap, self.target = hm, target


def _hm(blocks) -> Heightmap:
    """Boxes (x, y, size_x, size_y, colour[, height]) on an empty table."""
    color = np.full((N, N, 3), (199, 178, 148), np.uint8)
    height = np.zeros((N, N), np.float32)
    for x, y, sx, sy, name, *h in blocks:
        r0, c0 = world_to_pixel(x - sx / 2, y - sy / 2, BOUNDS, RES)
        r1, c1 = world_to_pixel(x + sx / 2, y + sy / 2, BOUNDS, RES)
        r0, c0 = max(r0, 0), max(c0, 0)
        height[r0:r1, c0:c1] = h[0] if h else 0.045
        color[r0:r1, c0:c1] = PALETTE[name]
    return Heightmap(color, height, np.ones((N, N), bool), RES, BOUNDS)


def _plan(hm: Heightmap, params: HeuristicParams | None = None, tabu=(), last_seen=None):
    planner = HeuristicPlanner(G, params)
    target = target_mask(hm.color, hm.valid, "green")
    act = planner.plan(hm, target, list(tabu), last_seen, np.random.default_rng(0))
    assert act.primitive in ("grasp", "push") and 0 <= act.rotation < planner.rotations
    assert 0 <= act.row < N and 0 <= act.col < N and act.why
    return planner, target, act


def _valid_or_none(planner: HeuristicPlanner, act) -> bool:
    """An optional action of the planner (push_of, grasp_of) is None or a primitive at a rotation and map cell."""
    return act is None or (act.primitive in ("grasp", "push") and 0 <= act.rotation < planner.rotations
                           and 0 <= act.row < N and 0 <= act.col < N)


# two target-coloured objects in opposite corners: the mask's mean lies between them, and the window examined
# around it (half-size 0.10 m) holds no target cell; the others stand around each piece so no grasp is free
SPLIT = [(-0.17, -0.17, CUBE, CUBE, "green"), (0.17, 0.17, CUBE, CUBE, "green")] + [
    (sx * 0.17 + dx * CUBE, sx * 0.17 + dy * CUBE, CUBE, CUBE, "blue")
    for sx in (-1, 1) for dx in (-1, 0, 1) for dy in (-1, 0, 1) if (dx or dy) and abs(sx * 0.17 + dx * CUBE) < 0.22
    and abs(sx * 0.17 + dy * CUBE) < 0.22]


def test_push_rule_with_no_target_cell_in_the_window_returns_none():
    planner = HeuristicPlanner(G)
    hm = _hm([(-0.17, -0.17, CUBE, CUBE, "green"), (0.17, 0.17, CUBE, CUBE, "green")])
    target = target_mask(hm.color, hm.valid, "green")
    window = CellWindow(hm, np.array([0.0, 0.0]), 0.05)  # no target cell inside
    assert planner.best_push(hm, target, window) is None  # not ValueError: zero-size array ... minimum


def test_a_target_in_pieces_far_apart_is_planned_on_its_largest_piece():
    # the mask's mean lies between the pieces: the window around it holds no target cell
    hm = _hm([(-0.17, -0.17, CUBE, CUBE, "green"), (0.18, 0.18, 0.04, 0.04, "green")])
    planner, target, act = _plan(hm)
    assert not target[planner.around(hm, target)[0].slice].any()
    # the 45 mm piece, not the 40 mm one nor the empty middle
    x, y = BOUNDS[0, 0] + (act.col + 0.5) * RES, BOUNDS[1, 0] + (act.row + 0.5) * RES
    assert act.primitive == "grasp" and math.hypot(x + 0.17, y + 0.17) < 0.01
    assert planner.grasp_of(hm, target) is not None and planner.push_of(hm, target) is not None


def test_a_boxed_in_target_in_pieces_gives_an_action_not_an_error():
    planner, target, act = _plan(_hm(SPLIT))
    assert _valid_or_none(planner, planner.push_of(_hm(SPLIT), target))  # the training guidance: no error either
    assert _valid_or_none(planner, planner.grasp_of(_hm(SPLIT), target))
    for n_pushes in (0, 10):  # also through the declutter rule
        act = planner.plan(_hm(SPLIT), target, [], None, np.random.default_rng(1), n_pushes)
        assert act is not None and _valid_or_none(planner, act) and act.why, n_pushes


@pytest.mark.parametrize("blocks", [
    [],  # an empty table
    [(0.05, 0.05, CUBE, CUBE, "blue")],  # no target cell at all
    [(0.0, 0.0, 0.006, 0.006, "green"), (0.05, 0.0, CUBE, CUBE, "blue")],  # a target of 9 cells (not visible)
    [(-0.215, 0.0, 0.03, CUBE, "green")],  # a target cut by the border of the map
    [(-0.224 + CUBE / 2, -0.224 + CUBE / 2, CUBE, CUBE, "green"),  # in a corner, boxed in by tall objects
     (-0.224 + 1.5 * CUBE, -0.224 + CUBE / 2, CUBE, CUBE, "blue", 0.12),
     (-0.224 + CUBE / 2, -0.224 + 1.5 * CUBE, CUBE, CUBE, "red", 0.12),
     (-0.224 + 1.5 * CUBE, -0.224 + 1.5 * CUBE, CUBE, CUBE, "yellow", 0.12)],
])
def test_degenerate_scenes_give_an_action(blocks):
    hm = _hm(blocks)
    planner, target, _ = _plan(hm)  # a valid action (asserted by _plan)
    assert _valid_or_none(planner, planner.push_of(hm, target))  # the training guidance: no error either
    assert _valid_or_none(planner, planner.grasp_of(hm, target))
    _, _, act = _plan(hm, last_seen=np.array([0.0, 0.0]))  # also when searching where the target was last seen
    assert act.why


def test_min_target_cells_zero_with_an_empty_mask():
    # min_target_cells = 0 must not send an empty mask into the rules (mean of no cells: NaN -> error)
    hm = _hm([(0.05, 0.05, CUBE, CUBE, "blue")])
    planner, target, act = _plan(hm, HeuristicParams(min_target_cells=0))
    assert not target.any()
    assert planner.push_of(hm, target) is None and planner.grasp_of(hm, target) is None


def test_last_resort_is_a_random_push():
    hm = _hm([(0.02, -0.03, 0.06, 0.03, "green")])
    act = HeuristicPlanner(G).fallback(hm, np.random.default_rng(0))
    assert act.primitive == "push" and "random" in act.why
    assert HeuristicPlanner(G).fallback(_hm([]), np.random.default_rng(0)).primitive == "push"


def test_the_heuristic_policy_acts_on_a_split_target():
    pol = make_policy("heuristic")
    pol.reset(0)
    for _ in range(3):
        d = pol.act(_Obs(_hm(SPLIT)))
        assert d.primitive in ("grasp", "push") and all(math.isfinite(v) for v in (d.x, d.y, d.z, d.yaw))
