"""pg_policy.decision.rules.grasp_search and the grasp check's part grasps: when none of Q_g's best cells passes the
check, grasps across a vessel's wall and on an upturned bowl's foot are proposed, and the pipeline asks them with
the map's tests (pg_policy.decision.rerank.rerank_among)."""

import numpy as np
import pytest
from rule_testing import context

from pg_core.geometry import load
from pg_core.heightmap import Heightmap, rotation_yaw
from pg_policy.decision.rerank import rerank_among
from pg_policy.decision.rules.grasp_check import JawGraspCheck
from pg_policy.decision.rules.grasp_search import GraspSearch
from pg_policy.decision.rules.pipeline import RulePipeline

GEO = load()
H = W = 224
C = 112
RES = GEO.heightmap.resolution
GREEN = (92, 168, 82)


def _upturned_bowl(neighbour: bool = False) -> tuple[Heightmap, np.ndarray]:
    """A 14.4 cm bowl upside down at the centre: a dome from 46 mm at its 6 cm foot ring (7 mm high, 5 mm wide) to
    the table; `neighbour`: a 6 cm high box where a finger closing along x lands."""
    rr, cc = np.mgrid[0:H, 0:W]
    r = np.hypot(rr - C, cc - C) * RES
    height = np.zeros((H, W), np.float32)
    dome = 0.046 * (1.0 - ((r - 0.03) / 0.042) ** 2)
    body = r <= 0.072
    height[body] = np.where(r <= 0.03, 0.046, dome)[body]
    height[(r <= 0.03) & (r > 0.025)] = 0.053
    color = np.zeros((H, W, 3), np.uint8)
    color[body] = GREEN
    target = body.copy()
    if neighbour:
        height[C - 6:C + 7, C + 24:C + 30] = 0.06
        color[C - 6:C + 7, C + 24:C + 30] = (200, 60, 60)
        target[C - 6:C + 7, C + 24:C + 30] = False
    return Heightmap(color, height, np.ones((H, W), bool), RES, GEO.workspace.bounds), target


def _bowl(rim: float = 0.05) -> tuple[Heightmap, np.ndarray]:
    """A 16 cm bowl standing: a 6 mm thick wall `rim` m high around a floor 5 mm above the table (0.02: a plate)."""
    rr, cc = np.mgrid[0:H, 0:W]
    r = np.hypot(rr - C, cc - C) * RES
    height = np.zeros((H, W), np.float32)
    height[r <= 0.08] = 0.005
    height[(r > 0.074) & (r <= 0.08)] = rim
    hm = Heightmap(np.full((H, W, 3), 90, np.uint8), height, np.ones((H, W), bool), RES, GEO.workspace.bounds)
    return hm, height > 0


@pytest.mark.parametrize("rotation", [0, 3, 4, 13])
def test_the_check_passes_a_grasp_on_an_upturned_bowls_foot_and_no_other_cell(rotation):
    hm, target = _upturned_bowl()
    check = JawGraspCheck.from_arg(GEO, "jaw-walls")
    assert check.passes(hm, target, rotation, C, C)
    assert check.passes_many(hm, target, np.array([rotation]), np.array([C]), np.array([C]))[0]
    assert not check.passes(hm, target, rotation, C, C + 25)  # on the foot ring's wall: no part centred there
    assert not check.passes(hm, target, rotation, C + 30, C)  # the dome: wider than the jaw, no part


def test_a_part_grasp_with_a_neighbour_under_a_finger_is_refused():
    hm, target = _upturned_bowl(neighbour=True)
    check = JawGraspCheck.from_arg(GEO, "jaw-walls")
    assert not check.passes(hm, target, 0, C, C)  # closing along x: the box stands where a finger comes down
    assert check.passes(hm, target, 4, C, C)  # closing along y: clear


def test_part_proposals_sit_on_the_foot_and_rim_proposals_cross_the_wall():
    search = GraspSearch(GEO)
    hm, target = _upturned_bowl()
    rots, rows, cols = search.part_candidates(context(hm, target))
    assert set(rots.tolist()) == set(range(16))
    assert np.hypot(rows - C, cols - C).max() <= 3 * np.sqrt(2) + 1e-9
    hm, target = _bowl()
    rots, rows, cols = search.rim_candidates(context(hm, target))
    assert rows.size > 100
    # each cell at the rotation whose line lies nearest its radial direction, and the opposite one
    radial = np.arctan2(rows - C, cols - C)
    off = np.abs(np.angle(np.exp(1j * 2 * (rotation_yaw(rots, 16) - radial)))) / 2
    assert off.max() <= np.pi / 16 + 0.15
    assert search.proposals(context(hm, target, visible=False)) is None
    hm, target = _bowl(rim=0.02)  # a plate's rim, 15 mm above its floor: under the pads' depth
    assert JawGraspCheck.from_arg(GEO, "jaw-walls").passes(hm, target, 0, C, C + 35)  # a rim grasp to the check
    assert search.rim_candidates(context(hm, target)) is None  # but never proposed


def test_the_pipeline_asks_the_proposals_when_no_best_cell_passes():
    hm, target = _upturned_bowl()
    q = np.zeros((16, H, W))
    q[:, target] = 0.2
    q[:, C - 20:C + 21, C - 20:C + 21] = 0.1  # the nets rank the foot low
    q[5, C + 30, C] = 1.0  # the nets' favourite: the dome, which no check passes
    ctx = context(hm, target)
    check = JawGraspCheck.from_arg(GEO, "jaw-walls")
    check.top_k = 5  # the best 5 cells: the dome only
    alone = RulePipeline([check]).apply({"grasp": q, "push": np.zeros_like(q)}, ctx)
    assert alone.push_instead and alone.vetoed["grasp"] and alone.proposed["grasp"] == ()
    both = RulePipeline([check, GraspSearch(GEO)]).apply({"grasp": q, "push": np.zeros_like(q)}, ctx)
    assert not both.push_instead and not both.vetoed["grasp"]
    assert both.proposed == {"grasp": ("grasp_search",), "push": ()}  # what the decision record names
    r, row, col = np.unravel_index(int(np.argmax(both.q["grasp"])), q.shape)
    assert float(both.q["grasp"][r, row, col]) == 1.0  # the map's best value: the grasp-or-push choice unchanged
    assert np.hypot(row - C, col - C) <= 3 * np.sqrt(2) + 1e-9 and check.passes(hm, target, int(r), int(row), int(col))


def test_rerank_among_takes_the_best_valued_passing_candidate():
    q = np.zeros((2, 4, 4))
    q[0, 0, 0], q[1, 2, 2], q[0, 3, 3], q[1, 1, 1] = 0.9, 0.5, 0.4, 0.3
    region = np.ones((4, 4), bool)
    cands = (np.array([0, 1, 1]), np.array([3, 1, 2]), np.array([3, 1, 2]))
    out, rank = rerank_among(q, region, lambda r, row, col: (r, row, col) != (1, 2, 2), cands)
    assert rank == 2 and out[0, 3, 3] == 0.9 and out[0, 0, 0] == -np.inf and out[1, 2, 2] == -np.inf
    assert np.unravel_index(int(np.argmax(out)), q.shape) == (0, 3, 3)
    same, none = rerank_among(q, region, lambda r, row, col: False, cands)
    assert none is None and np.array_equal(same, q)
    outside = np.zeros((4, 4), bool)
    outside[0, 0] = True
    assert rerank_among(q, outside, lambda r, row, col: True, cands)[1] is None  # candidates outside the region
