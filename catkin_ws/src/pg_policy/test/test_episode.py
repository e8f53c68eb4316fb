"""The one episode protocol (pg_policy.target_loop.episode): limits, counting, the order of the termination reasons,
target_lost (the memory's evidence and the simulator's ground truth), the futile-push refusal, the seed convention;
and the ROS loop on it (scripted source, executor and policy of test_target_loop)."""

from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np
import pytest
from test_target_loop import Clock, Executor, Policy, Source

from pg_core.heightmap import Heightmap
from pg_core.palette import palette_rgb
from pg_core.seeds import MIN_EVAL_SEED, train_seed
from pg_policy.perception.target_memory import SEARCH_LIMIT_TRACKED
from pg_policy.target_loop import episode as E
from pg_policy.target_loop.episode import Episode, Limits, Outcome, check_eval_seed, check_train_seed
from pg_policy.target_loop.loop_limits import LoopLimits
from pg_policy.target_loop.loop_types import LoopError, StampedHeightmap
from pg_policy.target_loop.target_loop import TargetLoop
from pg_policy.target_loop.target_spec import PointTarget

N = 224
BOUNDS = np.array([[-0.224, 0.224], [-0.224, 0.224], [0.0, 0.4]])


def grasp(x: float = 0.0):
    return SimpleNamespace(primitive="grasp", rotation=0, x=x, y=0.0)


def push(rotation: int = 0, x: float = 0.0, y: float = 0.0):
    return SimpleNamespace(primitive="push", rotation=rotation, x=x, y=y)


def scene(target_at: tuple[int, int] | None, cover: tuple[int, int] | None = None) -> tuple[Heightmap, np.ndarray]:
    """(heightmap, target mask): a 20 x 20 cell green block at (row, col) target_at (None: none), and a taller blue
    block of 30 x 30 cells at `cover`."""
    color = np.full((N, N, 3), (199, 178, 148), np.uint8)
    height = np.zeros((N, N), np.float32)
    mask = np.zeros((N, N), bool)
    if target_at is not None:
        r, c = target_at
        color[r:r + 20, c:c + 20], height[r:r + 20, c:c + 20] = palette_rgb("green"), 0.045
        mask[r:r + 20, c:c + 20] = True
    if cover is not None:
        r, c = cover
        color[r:r + 30, c:c + 30], height[r:r + 30, c:c + 30] = palette_rgb("blue"), 0.09
        mask[r:r + 30, c:c + 30] = False
    return Heightmap(color, height, np.ones((N, N), bool), 0.002, BOUNDS), mask


# -- limits and counting ------------------------------------------------------------------------------------------
def test_limits_are_validated_and_default_to_the_protocol_budget():
    assert (Limits().max_actions, Limits().max_failed_grasps) == (30, 5)
    for bad in ({"max_actions": 0}, {"max_failed_grasps": -1}, {"max_actions": True}, {"max_actions": 2.5}):
        with pytest.raises(ValueError, match=f"^{next(iter(bad))} must be an integer >= 1"):
            Limits(**bad)


def test_counting_refusals_attempts_and_pushes():
    ep = Episode(Limits(10, 5))
    ep.record(push(), Outcome())
    ep.record(grasp(), Outcome(refused=True, message="refused: unreachable"))
    ep.record(grasp(), Outcome())
    assert (ep.actions, ep.pushes, ep.grasps, ep.failed_grasps, ep.refused) == (3, 1, 1, 1, 1)
    assert not ep.over() and ep.termination == ""


@pytest.mark.parametrize(("steps", "limits", "termination", "why"), [
    # the target grasped on the last allowed action completes the episode (the budget is spent too)
    ([(grasp(), Outcome())] * 2 + [(grasp(), Outcome(target_grasped=True))], Limits(3, 3), E.COMPLETED,
     "target 'green' grasped"),
    ([(grasp(), Outcome())] * 3, Limits(3, 3), E.FAILED_GRASPS, "gave up after 3 failed grasps"),
    ([(push(), Outcome())] * 4, Limits(4, 5), E.MAX_ACTIONS, "action budget of 4 spent"),
])
def test_termination_order(steps, limits, termination, why):
    ep = Episode(limits, target="green")
    for d, o in steps:
        assert not ep.over()
        ep.record(d, o)
    assert ep.over() and (ep.termination, ep.why) == (termination, why)
    assert ep.completed == (termination == E.COMPLETED)


def test_target_lost_comes_before_the_budgets_and_a_stop_reason_stands():
    ep = Episode(Limits(1, 1))
    hm, _ = scene(None)
    ep.record(grasp(), Outcome())  # the last action, and a failed grasp
    ep.observe(hm, np.zeros((N, N), bool), truth_outside=True)
    assert ep.over() and ep.termination == E.TARGET_LOST
    assert ep.why == "target lost: outside the workspace (simulator ground truth)"
    ep.stop(E.CANCELLED, "cancelled")  # too late: the first reason stands
    assert ep.termination == E.TARGET_LOST
    with pytest.raises(ValueError, match="unknown termination"):
        Episode().stop("bored", "")


def test_refusals_in_a_row_end_only_the_loops_that_ask():
    loop_ep, trial_ep = Episode(Limits(10, 5), max_refused_in_row=3), Episode(Limits(10, 5))
    for ep in (loop_ep, trial_ep):
        for _ in range(3):
            ep.record(grasp(), Outcome(refused=True, message="refused: unreachable"))
    assert loop_ep.over() and loop_ep.termination == E.REFUSED
    assert loop_ep.why == "3 primitives in a row failed, last: refused: unreachable"
    assert not trial_ep.over()


def test_goal_agnostic_episodes_never_complete_and_count_lifts_as_successes():
    ep = Episode(Limits(3, 1), goal_agnostic=True)
    ep.record(grasp(), Outcome(target_grasped=True))
    ep.record(grasp(), Outcome(target_grasped=True))
    assert not ep.over() and ep.failed_grasps == 0
    ep.record(grasp(), Outcome())
    assert ep.over() and ep.termination == E.FAILED_GRASPS


# -- target lost ------------------------------------------------------------------------------------------------------
def test_ground_truth_confirms_or_overrules_the_evidence():
    hm_edge, edge = scene((0, 100))  # partly outside: on the border row
    hm_gone, gone = scene(None)
    for truth, termination in ((None, E.TARGET_LOST), (True, E.TARGET_LOST), (False, "")):
        ep = Episode()
        ep.observe(hm_edge, edge, truth_outside=None if truth is None else False)
        ep.record(push(), Outcome())
        ep.observe(hm_gone, gone, truth_outside=truth)
        assert ep.over() == bool(termination) and ep.termination == termination
        if truth:
            assert ep.why == "target lost: seen leaving the workspace at (-0.004, -0.204) (confirmed by the simulator)"


def test_a_target_hidden_in_the_middle_is_never_lost():
    ep = Episode()
    hm, mask = scene((100, 100))
    ep.observe(hm, mask)
    hidden, none = scene(None, cover=(95, 95))
    for _ in range(10):
        ep.record(push(len(range(ep.actions)) % 16), Outcome())
        ep.observe(hidden, none)
        assert not ep.over()
    assert ep.search.hidden_for == 10 and ep.search.last_seen is not None


def test_a_search_that_finds_nothing_ends_as_not_found():
    """Hidden with nothing over the last-seen place: target_not_found after the search limit, which the ground
    truth does not overrule; an observation with something over that place starts the count again."""
    hm, mask = scene((100, 100))
    gone, none = scene(None)  # the target nowhere, nothing over where it was
    covered, _ = scene(None, cover=(95, 95))
    for limit in (E.SEARCH_LIMIT_EXACT, SEARCH_LIMIT_TRACKED):
        ep = Episode(search_limit=limit)
        ep.observe(hm, mask)
        views = [gone] * (limit - 1) + [covered] + [gone] * limit
        for i, view in enumerate(views):
            assert not ep.over()
            ep.record(push(i % 16), Outcome())
            ep.observe(view, none, truth_outside=False)
        assert ep.over() and ep.termination == E.TARGET_NOT_FOUND and ep.actions == 2 * limit
        assert ep.why == (f"target not found: not in view for {limit} observations in a row, and nothing covers where "
                          "it was last seen (-0.004, -0.004)")
    for ep in (Episode(search_limit=None), Episode(goal_agnostic=True)):
        ep.observe(hm, mask)
        for i in range(12):
            ep.record(push(i % 16), Outcome())
            ep.observe(gone, none)
        assert not ep.over() and ep.search.uncovered_for == 12
    for bad in (0, -1, 2.5, True):
        with pytest.raises(ValueError, match="search_limit"):
            Episode(search_limit=bad)


# -- futile pushes ----------------------------------------------------------------------------------------------------
def test_a_push_that_changed_nothing_is_refused_when_repeated():
    ep = Episode()
    hm, mask = scene((100, 100))
    ep.observe(hm, mask)
    ep.record(push(3, 0.01, 0.02), Outcome())
    ep.observe(hm, mask)  # nothing moved
    assert ep.vet(push(3, 0.015, 0.02)).startswith(E.FUTILE_PUSH_REFUSAL)
    assert ep.vet(push(4, 0.01, 0.02)) is None and ep.vet(push(3, 0.05, 0.02)) is None
    assert ep.vet(grasp(0.01)) is None
    ep.record(push(5, 0.01, 0.02), Outcome())
    moved, moved_mask = scene((100, 130))
    ep.observe(moved, moved_mask)  # this push moved the block: remembered as useful, not futile
    assert ep.vet(push(5, 0.01, 0.02)) is None


def test_a_refused_push_is_not_judged():
    ep = Episode()
    hm, mask = scene((100, 100))
    ep.observe(hm, mask)
    ep.record(push(3), Outcome(refused=True))
    ep.observe(hm, mask)
    assert ep.vet(push(3)) is None


# -- seeds ------------------------------------------------------------------------------------------------------------
def test_seed_convention():
    check_eval_seed(MIN_EVAL_SEED)
    with pytest.raises(ValueError, match="training"):
        check_eval_seed(MIN_EVAL_SEED - 1)
    check_eval_seed(3, allow_train_seeds=True)
    check_train_seed(MIN_EVAL_SEED - 1)
    with pytest.raises(ValueError, match="evaluation seeds are above"):
        check_train_seed(MIN_EVAL_SEED)
    assert all(0 <= train_seed(s, e) < MIN_EVAL_SEED for s in (0, 7, 999_999) for e in (1, 10**7))


# -- the ROS loop on the protocol -------------------------------------------------------------------------------------
class MovingSource(Source):
    """A source whose target block sits at `at` (row, col) and whose executor hides it (lifts=True in the script)."""

    def __init__(self, clock: Clock, at: tuple[int, int], cover: tuple[int, int] | None = (95, 95)) -> None:
        super().__init__(clock)
        self.at, self.cover = at, cover  # cover: where a block stands once the target is hidden (None: nowhere)

    def wait_after(self, stamp: float, timeout_s: float) -> StampedHeightmap:
        self.requests += 1
        self.clock.t = stamp + 0.5
        hm, _ = scene(self.at if self.target_present else None, None if self.target_present else self.cover)
        return StampedHeightmap(hm, self.clock.t)


def loop_of(at: tuple[int, int], script, primitive="push", repeat=False, cover=(95, 95)):
    clock = Clock()
    source = MovingSource(clock, at, cover)
    ex = Executor(clock, source, script)
    policy = Policy(primitive, repeat)
    return TargetLoop(policy, source, ex, clock), source, ex, policy


def test_a_target_hidden_mid_call_is_searched_for_not_an_error():
    loop, _, ex, policy = loop_of((100, 100), [(True, False, True)])  # the first push hides the target
    res = loop.run("green", LoopLimits(max_actions=4))
    assert res.termination == E.MAX_ACTIONS and len(ex.calls) == 4 and "budget" in res.message
    searches = policy.searches
    assert searches[0].visible and not any(s.visible for s in searches[1:])
    assert searches[-1].last_seen.index == 0 and searches[-1].hidden_for == 3


def test_a_target_seen_leaving_ends_the_call_as_lost():
    loop, _, ex, _ = loop_of((1, 100), [(True, False, True)])  # on the border, then gone after the first push
    res = loop.run("green")
    assert not res.success and res.termination == E.TARGET_LOST and len(ex.calls) == 1
    assert res.message.startswith("target lost: seen leaving the workspace at (")


def test_a_target_hidden_after_the_edge_is_lost_within_two_actions():
    loop, _, ex, _ = loop_of((8, 100), [(True, False, True)])  # 8 cells from the border, then gone
    res = loop.run("green")
    assert res.termination == E.TARGET_LOST and len(ex.calls) == 2
    assert res.message.startswith("target lost: hidden for 2 actions since last seen at the workspace edge")


def test_a_call_whose_search_finds_nothing_ends_as_not_found():
    """The target gone from the middle with nothing over its place: a colour call ends after SEARCH_LIMIT_EXACT
    actions (the first push and the searching ones), a point call (tracked) after SEARCH_LIMIT_TRACKED."""
    for target, limit in (("green", E.SEARCH_LIMIT_EXACT), (PointTarget(-0.004, -0.004), SEARCH_LIMIT_TRACKED)):
        loop, _, ex, _ = loop_of((100, 100), [(True, False, True)], cover=None)
        res = loop.run(target)
        assert not res.success and res.termination == E.TARGET_NOT_FOUND and len(ex.calls) == limit
        assert res.message.startswith(f"target not found: not in view for {limit} observations in a row")


def test_a_target_not_visible_at_the_start_is_refused_before_anything_moves():
    loop, source, ex, _ = loop_of((100, 100), [(True, False, False)])
    source.target_present = False
    with pytest.raises(LoopError, match="not visible"):
        loop.run("green")
    assert ex.calls == []


def test_a_futile_push_is_not_repeated_by_the_loop():
    loop, _, ex, _ = loop_of((100, 100), [(True, False, False)], repeat=True)  # the same push on a still scene
    res = loop.run("green")
    assert len(ex.calls) == 1 and res.pushes == 1 and res.refused == 3 and res.termination == E.REFUSED
    assert res.actions[1].execution.message.startswith(E.FUTILE_PUSH_REFUSAL)
    assert not any(math.isnan(r.decision.q) for r in res.actions)
