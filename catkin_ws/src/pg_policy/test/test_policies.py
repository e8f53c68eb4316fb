"""The policy registry, the random and heuristic baselines and the learned policy on synthetic heightmaps (the heuristic
in the simulator: pg_learning/test/test_sim_env.py)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pytest

from pg_core.geometry import load
from pg_core.heightmap import Heightmap, world_to_pixel
from pg_core.palette import PALETTE
from pg_policy.policies.heuristic import HeuristicPolicy
from pg_policy.policies.learned import HIDDEN_PUSHES
from pg_policy.policies.model_files import SHIPPED_MODELS, resolve_models
from pg_policy.policies.policy import Policy, PolicyOptions, observed_target
from pg_policy.policies.registry import UnknownPolicyError, make_policy, policies

G = load()
BOUNDS = G.workspace.bounds
RES = G.heightmap.resolution


@dataclass
class _Obs:
    heightmap: Heightmap
    target: str = "green"


def _scene(blocks: list[tuple[float, float, float, float, str]]) -> _Obs:
    """Axis-aligned boxes (x, y, size_x, size_y, colour) 0.045 m tall on an empty table."""
    n = G.heightmap.rows
    color = np.full((n, n, 3), (199, 178, 148), np.uint8)
    height = np.zeros((n, n), np.float32)
    for x, y, sx, sy, name in blocks:
        r0, c0 = world_to_pixel(x - sx / 2, y - sy / 2, BOUNDS, RES)
        r1, c1 = world_to_pixel(x + sx / 2, y + sy / 2, BOUNDS, RES)
        height[r0:r1, c0:c1] = 0.045
        color[r0:r1, c0:c1] = PALETTE[name]
    return _Obs(Heightmap(color, height, np.ones((n, n), bool), RES, BOUNDS))


CUBE = 0.045


def learned(model_dir, overrides: dict) -> Policy:
    """The learned policy of `model_dir` with option `overrides` (pg_policy.policies.options)."""
    return make_policy("learned", PolicyOptions(models=(model_dir,), overrides=overrides))


def test_registry_and_errors(tmp_path):
    assert {"random", "heuristic", "grasp-only", "learned"} <= set(policies())
    with pytest.raises(UnknownPolicyError, match="random, heuristic, grasp-only, learned"):
        make_policy("greedy")
    with pytest.raises(FileNotFoundError, match="needs a model"):
        make_policy("learned")
    (tmp_path / "grasp.pt").write_bytes(b"")
    with pytest.raises(FileNotFoundError, match="push.pt"):
        resolve_models([tmp_path], need_push=True)
    assert resolve_models([tmp_path], need_push=False) == (tmp_path / "grasp.pt", None)
    with pytest.raises(FileNotFoundError, match="not found"):
        resolve_models([tmp_path / "grasp.pt", tmp_path / "push.pt"], need_push=True)
    assert isinstance(make_policy("heuristic"), Policy) and make_policy("random").q_maps() == {}


def test_random_policy_is_seeded_and_target_centred():
    obs = _scene([(0.05, -0.03, CUBE, CUBE, "green"), (-0.1, 0.1, CUBE, CUBE, "blue")])
    pol = make_policy("random", PolicyOptions(seed=1))
    runs = []
    for _ in range(2):
        pol.reset(42)
        runs.append([pol.act(obs) for _ in range(20)])
    assert runs[0] == runs[1]
    assert {d.primitive for d in runs[0]} == {"grasp", "push"}
    for d in runs[0]:
        assert abs(d.x - 0.05) < CUBE / 2 + 0.025 and abs(d.y + 0.03) < CUBE / 2 + 0.025
        assert d.yaw == pytest.approx(d.rotation * math.pi / 8)


def _heuristic(obs):
    pol = make_policy("heuristic")
    pol.reset(0)
    return pol.act(obs)


def test_heuristic_grasps_an_isolated_target_at_its_centre():
    d = _heuristic(_scene([(0.03, 0.02, CUBE, CUBE, "green"), (-0.12, -0.1, CUBE, 0.09, "blue")]))
    assert d.primitive == "grasp" and abs(d.x - 0.03) < 0.004 and abs(d.y - 0.02) < 0.004
    assert d.z == pytest.approx(G.primitives.grasp_min_z)


def test_heuristic_grasps_across_the_free_axis():
    # neighbours touch the target on -x and +x: the fingers must close along y (yaw 90 deg)
    d = _heuristic(_scene([(0.0, 0.0, CUBE, CUBE, "green"), (-CUBE, 0.0, CUBE, CUBE, "blue"),
                           (CUBE, 0.0, CUBE, CUBE, "red")]))
    assert d.primitive == "grasp" and d.rotation % 8 == 4


def test_heuristic_pushes_a_boxed_in_target_into_free_space():
    blocks = [(0.0, 0.0, CUBE, CUBE, "green")] + [
        (dx * CUBE, dy * CUBE, CUBE, CUBE, "blue") for dx in (-1, 0, 1) for dy in (-1, 0, 1) if dx or dy]
    blocks += [(-0.12, dy, CUBE, CUBE, "red") for dy in (-0.1, -0.05, 0.0, 0.05, 0.1)]  # a wall on the -x side
    obs = _scene(blocks)
    pol = make_policy("heuristic")
    pol.reset(0)
    d = pol.act(obs)
    assert d.primitive == "push"
    assert math.cos(d.yaw) > 0.3  # away from the wall
    assert isinstance(pol, HeuristicPolicy) and "push target out" in pol.last_action.why


def test_heuristic_does_not_repeat_a_failed_grasp():
    obs = _scene([(0.0, 0.0, CUBE, CUBE, "green"), (-CUBE, 0.0, CUBE, CUBE, "blue"), (CUBE, 0.0, CUBE, CUBE, "red")])
    pol = make_policy("heuristic")
    pol.reset(0)
    first, second = pol.act(obs), pol.act(obs)  # a second act() on the same scene: the first grasp failed
    assert first.primitive == "grasp"
    same_place = math.hypot(second.x - first.x, second.y - first.y) < pol.planner.p.repeat_radius
    assert not (second.primitive == "grasp" and second.rotation % 8 == first.rotation % 8 and same_place)


def test_learned_policies_from_exported_files(model_dir):
    obs = _scene([(0.03, 0.02, CUBE, CUBE, "green"), (-0.1, 0.1, CUBE, CUBE, "blue")])
    pol = make_policy(str(model_dir))  # a directory with grasp.pt and push.pt runs `learned`
    assert pol.name == "learned" and pol.threshold == 1.8
    d = pol.act(obs)
    q = pol.q_maps()
    assert q["grasp"].shape == q["push"].shape == (16, G.heightmap.rows, G.heightmap.cols)
    assert d.primitive == ("grasp" if d.grasp_q > 1.8 else "push")
    flip = 1e9 if d.grasp_q > 1.8 else -1e9
    flipped = learned(model_dir, {"grasp_threshold": flip})
    assert flipped.act(obs).primitive != d.primitive
    g = make_policy("grasp-only", PolicyOptions(models=(model_dir / "grasp.pt",)))
    d = g.act(obs)
    r, c = world_to_pixel(0.03, 0.02, BOUNDS, RES)  # the grasp lies on the target
    assert d.primitive == "grasp" and abs(d.row - r) <= 12 and abs(d.col - c) <= 12 and set(g.q_maps()) == {"grasp"}
    with pytest.raises(ValueError, match="expected 'grasp'"):
        make_policy("grasp-only", PolicyOptions(models=(model_dir / "push.pt",)))



def test_learned_push_budget_forces_a_grasp_after_that_many_pushes(model_dir):
    obs = _scene([(0.03, 0.02, CUBE, CUBE, "green"), (-0.1, 0.1, CUBE, CUBE, "blue")])
    pol = learned(model_dir, {"grasp_threshold": 1e9, "push_budget": 2})
    assert [pol.act(obs).primitive for _ in range(4)] == ["push", "push", "grasp", "push"]
    pol.reset(0)
    assert pol.act(obs).primitive == "push" and pol.pushes_in_row == 1
    none = learned(model_dir, {"grasp_threshold": 1e9})  # metadata: no budget
    assert none.push_budget == 0 and [none.act(obs).primitive for _ in range(3)] == ["push"] * 3
    with pytest.raises(ValueError, match="push budget"):
        learned(model_dir, {"push_budget": -1})


def test_learned_policy_does_not_repeat_a_failed_grasp(model_dir):
    obs = _scene([(0.03, 0.02, CUBE, CUBE, "green"), (-0.1, 0.1, CUBE, CUBE, "blue")])
    pol = learned(model_dir, {"grasp_threshold": -1e9})  # always grasps
    first, second = pol.act(obs), pol.act(obs)  # asked again on the same scene: the first grasp failed
    assert first.primitive == second.primitive == "grasp"
    assert (first.rotation % 8, first.row, first.col) != (second.rotation % 8, second.row, second.col)
    pol.reset(0)  # a new trial forgets
    assert pol.act(obs) == first and pol.rules["failed_grasps"].grasps == []
    off = learned(model_dir, {"grasp_threshold": -1e9, "failed_grasp_radius": 0})
    assert [(d.rotation, d.row, d.col) for d in (off.act(obs), off.act(obs))] == [(first.rotation, first.row,
                                                                                   first.col)] * 2


def test_learned_policy_does_not_repeat_a_futile_push(model_dir):
    obs = _scene([(0.03, 0.02, CUBE, CUBE, "green"), (0.08, 0.02, CUBE, CUBE, "blue")])
    pol = learned(model_dir, {"grasp_threshold": 1e9, "futile_push_radius": 0.01})
    first, second = pol.act(obs), pol.act(obs)  # always pushes, on an unchanged scene
    assert first.primitive == second.primitive == "push" and len(pol.rules["futile_pushes"].pushes) == 1
    assert (first.rotation, first.row, first.col) != (second.rotation, second.row, second.col)
    pol.reset(0)
    assert pol.act(obs) == first and pol.rules["futile_pushes"].pushes == []
    off = learned(model_dir, {"grasp_threshold": 1e9})  # default: off
    assert [(d.rotation, d.row, d.col) for d in (off.act(obs), off.act(obs))] == [(first.rotation, first.row,
                                                                                   first.col)] * 2


def test_shipped_models_resolve_by_folder_name():
    pol = make_policy("lite")
    assert pol.name == "learned" and pol.model_paths[0] == SHIPPED_MODELS / "lite" / "grasp.pt"
    with pytest.raises(ValueError, match="unknown policy"):
        make_policy("no_such_model")

def test_heuristic_uncovers_a_hidden_target():
    obs = _scene([(0.0, 0.0, CUBE, CUBE, "blue"), (0.1, 0.1, CUBE, CUBE, "red")])  # no green cell at all
    pol = make_policy("heuristic")
    pol.reset(0)
    pol.last_seen = np.array([0.01, 0.0])  # the target was last seen under the blue block
    d = pol.act(obs)
    assert d.primitive == "grasp" and abs(d.x) < 0.01 and abs(d.y) < 0.01 and "uncover" in pol.last_note


def test_learned_policies_apply_the_grasp_filter(model_dir):
    from pg_policy.decision.decision import masked_max
    from pg_policy.decision.rules.grasp_filter import GraspFilter

    obs = _scene([(0.03, 0.02, CUBE, CUBE, "green"), (-0.1, 0.1, CUBE, CUBE, "blue")])
    # full maps (q_window off), so that the whole filtered map can be compared; the windowed policy decides alike
    raw = make_policy("learned", PolicyOptions(models=(model_dir,), overrides={"q_window": False}))
    assert "grasp_filter" not in raw.rules  # metadata has no filter: none
    d_raw = raw.act(obs)
    pol = learned(model_dir, {"grasp_filter": "sym+min3", "q_window": False})
    d = pol.act(obs)
    windowed = learned(model_dir, {"grasp_filter": "sym+min3"}).act(obs)
    assert (windowed.primitive, windowed.rotation, windowed.row, windowed.col) == (d.primitive, d.rotation, d.row,
                                                                                   d.col)
    filtered = GraspFilter.parse("sym+min3").apply(raw.q_maps()["grasp"])  # same nets, same observation
    np.testing.assert_allclose(pol.q_maps()["grasp"], filtered)  # q_maps() shows the map the decision used
    np.testing.assert_array_equal(pol.q_maps()["push"], raw.q_maps()["push"])
    target = observed_target(obs) & obs.heightmap.valid
    assert d.grasp_q == pytest.approx(masked_max(filtered, target)) and d.grasp_q <= d_raw.grasp_q
    go = make_policy("grasp-only", PolicyOptions(models=(model_dir / "grasp.pt",), overrides={"grasp_filter": "min5"}))
    g = go.act(obs)
    assert g.q == pytest.approx(masked_max(GraspFilter.parse("min5").apply(raw.q_maps()["grasp"]), target))
    with pytest.raises(ValueError, match="bad grasp filter"):
        learned(model_dir, {"grasp_filter": "max3"})


def test_grasp_filter_default_comes_from_the_model_metadata(model_dir, tmp_path):
    import shutil

    from pg_policy.models.model_io import export_qnet, load_qnet

    for role in ("grasp", "push"):
        net, meta = load_qnet(model_dir / f"{role}.pt")
        meta["thresholds"] = {**meta.get("thresholds", {}), "grasp_filter": "min3"}
        export_qnet(net, tmp_path / f"{role}.pt", meta)
    assert make_policy(str(tmp_path)).rules["grasp_filter"].spec() == "grasp_filter:min3"
    assert "grasp_filter" not in make_policy(str(tmp_path), PolicyOptions(overrides={"grasp_filter": "none"})).rules
    shutil.rmtree(tmp_path)


def test_grasp_check_comes_from_the_option_else_the_model_metadata(model_dir, tmp_path):
    from pg_policy.models.model_io import export_qnet, load_qnet

    assert "grasp_check" not in make_policy("learned", PolicyOptions(models=(model_dir,))).rules  # no metadata entry
    for role in ("grasp", "push"):
        net, meta = load_qnet(model_dir / f"{role}.pt")
        meta["thresholds"] = {**meta.get("thresholds", {}), "grasp_check": "jaw"}
        export_qnet(net, tmp_path / f"{role}.pt", meta)
    assert make_policy(str(tmp_path)).rules["grasp_check"].variant == "jaw"
    assert "grasp_check" not in make_policy(str(tmp_path), PolicyOptions(overrides={"grasp_check": "none"})).rules
    with pytest.raises(ValueError, match="grasp_check: expected one of"):
        make_policy(str(tmp_path), PolicyOptions(overrides={"grasp_check": "fancy"}))


def test_the_shipped_model_brings_its_test_time_rules():
    # docs/RESULTS.md reports `lite` with these; `make train` exports them (scripts/train_recipe.sh)
    lite = make_policy("lite")
    assert lite.rules.specs() == ["grasp_filter:min3", "failed_grasps:0.01", "low_parts", "grasp_check:jaw-walls",
                                  "grasp_search", "push_landing", "edge_guard"]
    assert lite.threshold == pytest.approx(0.7) and lite.push_budget == 3
    assert "grasp_check" not in make_policy("lite", PolicyOptions(overrides={"grasp_check": "none"})).rules


def test_the_grasp_check_moves_a_blocked_grasp_and_keeps_the_decision(model_dir):
    # The check only re-ranks Q_g: same primitive and same compared value; the chosen grasp passes the jaw test.
    from pg_policy.decision.rules.grasp_check import JawGraspCheck

    obs = _scene([(0.0, 0.0, CUBE, CUBE, "green"), (0.06, 0.0, CUBE, CUBE, "blue"), (-0.06, 0.0, CUBE, CUBE, "red")])
    plain = learned(model_dir, {"grasp_threshold": -1e9})
    checked = learned(model_dir, {"grasp_threshold": -1e9, "grasp_check": "jaw"})
    # every cell is a candidate: the untrained net's best 200 may all close along x
    checked.rules["grasp_check"].top_k = 10**6
    d0, d1 = plain.act(obs), checked.act(obs)
    assert d0.primitive == d1.primitive == "grasp" and d1.grasp_q == pytest.approx(d0.grasp_q)
    target = observed_target(obs)
    assert not JawGraspCheck(plain.geometry).passes(obs.heightmap, target, d0.rotation, d0.row, d0.col)
    assert JawGraspCheck(plain.geometry).passes(obs.heightmap, target, d1.rotation, d1.row, d1.col)


def test_the_landing_guard_moves_a_push_off_the_objects_and_keeps_the_decision(model_dir):
    # A target boxed in on all four sides, grasp threshold +inf: every decision is a push. The guard only re-ranks
    # Q_p: same compared push value, and the chosen push's closed jaw lands beside the objects, not on them.
    from pg_policy.decision.rules.push_landing import LandingGuard

    obs = _scene([(0.0, 0.0, CUBE, CUBE, "green"), (0.05, 0.0, CUBE, CUBE, "blue"), (-0.05, 0.0, CUBE, CUBE, "red"),
                  (0.0, 0.05, CUBE, CUBE, "yellow"), (0.0, -0.05, CUBE, CUBE, "orange")])
    plain = learned(model_dir, {"grasp_threshold": 1e9})
    guarded = learned(model_dir, {"grasp_threshold": 1e9, "push_landing": True})
    guarded.rules["push_landing"].top_k = 10**6  # the untrained net's best 200 may all land
    d0, d1 = plain.act(obs), guarded.act(obs)
    assert d0.primitive == d1.primitive == "push" and d1.q == pytest.approx(d0.q)
    landing = LandingGuard(plain.geometry)
    assert landing.cover(obs.heightmap.height, d0.rotation, d0.row, d0.col) > landing.max_cover
    assert landing.cover(obs.heightmap.height, d1.rotation, d1.row, d1.col) <= landing.max_cover


def test_the_rules_see_only_the_valid_cells_the_decision_chooses_among(model_dir):
    # decide() chooses among the heightmap's valid cells. Cells without a depth reading (shadows beside tall objects)
    # must be out of the regions the rules re-rank too: otherwise the guard's first passing push can be a cell the
    # decision never takes, and the push falls to the best valid cell, which no rule checked.
    from pg_policy.decision.rules.push_landing import LandingGuard

    obs = _scene([(0.0, 0.0, CUBE, CUBE, "green"), (0.05, 0.0, CUBE, CUBE, "blue"), (-0.05, 0.0, CUBE, CUBE, "red"),
                  (0.0, 0.05, CUBE, CUBE, "yellow"), (0.0, -0.05, CUBE, CUBE, "orange")])
    valid = np.ones_like(obs.heightmap.valid)
    valid[:, ::2] = False  # every other column without a depth reading
    obs = _Obs(Heightmap(obs.heightmap.color, obs.heightmap.height, valid, RES, BOUNDS))
    guarded = learned(model_dir, {"grasp_threshold": 1e9, "push_landing": True})
    guard = guarded.rules["push_landing"]
    guard.top_k = 10**6
    asked = []

    def test(ctx):
        inner = LandingGuard.candidate_test(guard, ctx)
        return lambda r, row, col: asked.append((row, col)) or inner(r, row, col)

    guard.candidate_test = test
    d = guarded.act(obs)
    assert d.primitive == "push" and valid[d.row, d.col] and asked
    assert all(valid[row, col] for row, col in asked)
    assert (d.row, d.col) == asked[-1]  # the decision is the push the guard passed
    assert guard.cover(obs.heightmap.height, d.rotation, d.row, d.col) <= guard.max_cover


def test_the_strict_check_pushes_when_no_grasp_passes_until_the_push_budget_is_spent(model_dir):
    # A target boxed in on all four sides: no jaw fits. "jaw" grasps anyway (threshold -1e9), "jaw-strict" pushes,
    # and grasps once the push budget (1) is spent: at the best cell passing the check's fallback tests (the target
    # fits between the pads, neighbours in the sweep allowed), or at Q_g's argmax with option forced_grasp off.
    obs = _scene([(0.0, 0.0, CUBE, CUBE, "green"), (0.05, 0.0, CUBE, CUBE, "blue"), (-0.05, 0.0, CUBE, CUBE, "red"),
                  (0.0, 0.05, CUBE, CUBE, "yellow"), (0.0, -0.05, CUBE, CUBE, "orange")])
    opts = {"grasp_threshold": -1e9, "push_budget": 1}
    jaw = learned(model_dir, {**opts, "grasp_check": "jaw"})
    assert jaw.act(obs).primitive == "grasp"
    strict = learned(model_dir, {**opts, "grasp_check": "jaw-strict"})
    strict.reset(0)
    first = strict.act(obs)
    assert first.primitive == "push" and "jaw check" in strict.last_note
    assert strict.act(obs).primitive == "grasp" and strict.last_note.startswith("push budget spent")
    plain = learned(model_dir, {**opts, "grasp_check": "jaw-strict", "forced_grasp": False})
    plain.reset(0)
    assert plain.act(obs).primitive == "push"
    assert plain.act(obs).primitive == "grasp" and plain.last_note == ""


def test_a_forced_grasp_that_no_fallback_passes_is_noted(model_dir):
    # a 10 x 10 cm target: wider than the open jaw both ways, and nothing like a rim or a raised part; once the
    # push budget (1) is spent the grasp goes to Q_g's argmax, and the decision record says why
    obs = _scene([(0.0, 0.0, 0.10, 0.10, "green")])
    strict = learned(model_dir, {"grasp_threshold": -1e9, "push_budget": 1, "grasp_check": "jaw-strict"})
    strict.reset(0)
    assert strict.act(obs).primitive == "push" and "jaw check" in strict.last_note
    assert strict.act(obs).primitive == "grasp"
    assert strict.last_note == "push budget spent: no grasp passes the grasp rules' fallback tests: Q_g's best"


def test_a_target_of_few_cells_is_the_goal_from_min_target_cells(model_dir):
    # a green sliver of 4 x 4 cells beside a blue block: below the default 25 cells the policy looks at every object
    # (goal-agnostic); with min_target_cells 5 it acts within the push region of the sliver (5 cm), never at the
    # block 14 cm away
    from pg_policy.policies.policy import goal_or_all

    obs = _scene([(0.0, 0.0, 0.008, 0.008, "green"), (0.1, 0.1, CUBE, CUBE, "blue")])
    assert int(observed_target(obs).sum()) == 16
    assert not goal_or_all(obs)[1] and goal_or_all(obs, 5)[1]
    d = learned(model_dir, {"min_target_cells": 5}).act(obs)
    assert math.hypot(d.x, d.y) <= 0.06, d
    with pytest.raises(ValueError, match="min_target_cells"):
        learned(model_dir, {"min_target_cells": 0})


def test_a_hidden_target_is_pushed_for_until_hidden_pushes_then_grasped(model_dir):
    # no green cell: goal-agnostic; a threshold below every Q_g grasps at once unless hidden_pushes asks for pushes
    obs = _scene([(0.0, 0.0, CUBE, CUBE, "blue"), (0.1, 0.1, CUBE, CUBE, "red")])
    eager = {"grasp_threshold": -1e9, "push_budget": 2}
    assert learned(model_dir, {**eager, "hidden_pushes": 0}).act(obs).primitive == "grasp"
    default = learned(model_dir, eager)
    assert default.hidden_pushes == HIDDEN_PUSHES and default.act(obs).primitive == "push"
    pol = learned(model_dir, {**eager, "hidden_pushes": 4})  # beyond the push budget while hidden
    assert [pol.act(obs).primitive for _ in range(5)] == ["push"] * 4 + ["grasp"]
    assert pol.act(obs).primitive == "push" and pol.last_note == "target hidden: push"
    visible = _scene([(0.03, 0.02, CUBE, CUBE, "green"), (-0.1, 0.1, CUBE, CUBE, "blue")])
    assert learned(model_dir, {**eager, "hidden_pushes": 4}).act(visible).primitive == "grasp"
    with pytest.raises(ValueError, match="hidden_pushes"):
        learned(model_dir, {"hidden_pushes": -1})


def test_a_push_the_edge_guard_refuses_is_never_made_the_policy_grasps_instead(model_dir):
    # every push candidate refused by the edge guard: with option refused_push (on by default) the policy grasps
    # although Q_g is below the threshold, off it makes the best refused push; refused by the landing guard alone (a
    # preference: a packed pile) it still pushes
    obs = _scene([(0.03, 0.02, CUBE, CUBE, "green"), (-0.1, 0.1, CUBE, CUBE, "blue")])

    def policy(refusing: str, **options: str) -> Policy:
        pol = learned(model_dir, {"grasp_threshold": 1e9, "edge_guard": "on", "push_landing": "on", **options})
        pol.rules[refusing].candidate_test = lambda ctx: (lambda r, row, col: False)
        return pol

    pol = policy("edge_guard")
    assert pol.act(obs).primitive == "grasp" and pol.last_note.startswith("every push is refused by the push rules")
    assert pol.pushes_in_row == 0
    assert policy("edge_guard", refused_push="off").act(obs).primitive == "push"
    assert policy("push_landing").act(obs).primitive == "push"

