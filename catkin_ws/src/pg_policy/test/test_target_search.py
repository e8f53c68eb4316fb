"""The target memory (pg_policy.perception.target_memory) and the policies that search with it: a hidden target's
search goal lies where it was last seen, the learned and heuristic policies act there, and neither repeats a push
that changed nothing."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from test_policies import CUBE, _scene, learned

from pg_core.heightmap import Heightmap
from pg_policy.perception.target_memory import (
    LOST_AFTER_HIDDEN,
    SEARCH_RADIUS_M,
    TargetMemory,
    TargetSearch,
)
from pg_policy.policies.policy import OBJECT_HEIGHT_M, goal_of, observed_target
from pg_policy.policies.registry import make_policy

A = (0.05, 0.03)  # where the target is last seen, then covered (world x, y in m)
B = (-0.12, -0.12)  # a neighbour far from it


@dataclass
class _Searching:
    heightmap: Heightmap
    target: str
    search: TargetSearch | None


def remembered(*observations: Any) -> TargetSearch:
    """The memory's search after seeing the observations in turn (no action between them)."""
    mem = TargetMemory()
    for i, obs in enumerate(observations):
        search = mem.see(obs.heightmap, observed_target(obs), i)
    return search


def hidden_scene() -> tuple[Any, Any]:
    """(seen, hidden): the green target at A beside a red block at B; then a taller blue block over A (no green)."""
    seen = _scene([(*A, CUBE, CUBE, "green"), (*B, CUBE, CUBE, "red")])
    hidden = _scene([(*A, 0.06, 0.06, "blue"), (*B, CUBE, CUBE, "red")])
    return seen, hidden


def centroid_xy(mask: np.ndarray, hm: Heightmap) -> np.ndarray:
    rows, cols = np.nonzero(mask)
    return np.array([hm.bounds[0, 0] + (cols.mean() + 0.5) * hm.resolution,
                     hm.bounds[1, 0] + (rows.mean() + 0.5) * hm.resolution])


def test_the_search_goal_of_a_hidden_target_lies_where_it_was_last_seen():
    seen, hidden = hidden_scene()
    search = remembered(seen, hidden)
    assert not search.visible and search.hidden_for == 1 and search.last_seen.index == 0
    assert np.allclose([search.last_seen.x, search.last_seen.y], A, atol=0.003)
    goal = search.goal(hidden.heightmap, OBJECT_HEIGHT_M)
    assert goal is not None and np.linalg.norm(centroid_xy(goal, hidden.heightmap) - A) < 0.01
    xy = centroid_xy(goal, hidden.heightmap)
    assert np.linalg.norm(xy - B) > 0.2  # the far neighbour is no part of it
    reach = SEARCH_RADIUS_M + CUBE
    rows, cols = np.nonzero(goal)
    hm = hidden.heightmap
    assert np.all(np.hypot(hm.bounds[0, 0] + (cols + 0.5) * hm.resolution - A[0],
                           hm.bounds[1, 0] + (rows + 0.5) * hm.resolution - A[1]) < reach)
    assert search.note(True) == "target hidden: searching where last seen (0.049, 0.029)"


def test_nothing_covering_the_last_seen_place_falls_back_to_every_object():
    seen, _ = hidden_scene()
    gone = _scene([(*B, CUBE, CUBE, "red")])
    search = remembered(seen, gone)
    assert search.goal(gone.heightmap, OBJECT_HEIGHT_M) is None
    goal = goal_of(_Searching(gone.heightmap, "green", search))
    assert not goal.visible and goal.mask.sum() == (gone.heightmap.height > OBJECT_HEIGHT_M).sum()
    assert goal.note == "target hidden: nothing covers where it was last seen (0.049, 0.029): every object"
    assert goal_of(gone).note == "target hidden"  # no memory at all


def test_lost_needs_the_edge():
    mem = TargetMemory()
    seen, hidden = hidden_scene()
    mem.see(seen.heightmap, observed_target(seen), 0)
    for i in range(1, 2 * LOST_AFTER_HIDDEN + 2):
        mem.see(hidden.heightmap, observed_target(hidden), i)
        assert mem.lost() is None  # hidden in the middle: searched for, never lost


def test_the_learned_policy_pushes_where_the_target_was_last_seen(model_dir):  # noqa: F811
    seen, hidden = hidden_scene()
    search = remembered(seen, hidden)
    pol = learned(model_dir, {"grasp_threshold": 1e9})
    d = pol.act(_Searching(hidden.heightmap, "green", search))
    assert d.primitive == "push" and np.hypot(d.x - A[0], d.y - A[1]) < 0.1, d
    assert pol.last_note == "target hidden: searching where last seen (0.049, 0.029): push"


def test_the_learned_policy_does_not_repeat_a_futile_push(model_dir):  # noqa: F811
    seen, _ = hidden_scene()
    pol = learned(model_dir, {"grasp_threshold": 1e9})
    first = pol.act(seen)
    futile = TargetSearch(True, 400, None, 0, ((first.rotation, first.x, first.y),))
    pol.reset(0)
    second = pol.act(_Searching(seen.heightmap, "green", futile))
    assert second.primitive == "push" and not futile.is_futile_repeat("push", second.rotation, second.x, second.y)


def test_the_heuristic_grasps_what_covers_the_last_seen_place():
    seen, hidden = hidden_scene()
    pol = make_policy("heuristic")
    pol.reset(0)
    d = pol.act(_Searching(hidden.heightmap, "green", remembered(seen, hidden)))
    assert d.primitive == "grasp" and np.hypot(d.x - A[0], d.y - A[1]) < 0.03, d
    assert pol.last_note == "target hidden: searching where last seen (0.049, 0.029): grasp blue object"
    assert np.allclose(pol.last_seen, A, atol=0.003)  # the memory's sighting


def test_the_heuristic_does_not_repeat_a_futile_push():
    obs = _scene([(0.0, 0.0, CUBE, CUBE, "green"), (0.03, 0.0, CUBE, 0.2, "blue"), (-0.03, 0.0, CUBE, 0.2, "red"),
                  (0.0, 0.03, 0.2, CUBE, "yellow"), (0.0, -0.03, 0.2, CUBE, "cyan")])  # boxed in: it pushes
    pol = make_policy("heuristic")
    pol.reset(0)
    first = pol.act(obs)
    assert first.primitive == "push"
    futile = TargetSearch(True, 400, None, 0, ((first.rotation, first.x, first.y),))
    second = pol.act(_Searching(obs.heightmap, "green", futile))
    assert not futile.is_futile_repeat(second.primitive, second.rotation, second.x, second.y)
