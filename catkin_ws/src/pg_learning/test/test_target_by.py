"""Evaluation with targets named by a point or a mask and scenes whose colours repeat (pg_learning.evaluation.target_by,
runner, report; pg_sim.world.recolour): the tracked mask's IoU per step, wrong-object grasps, the refusal of colour
targets where colours repeat."""

from __future__ import annotations

import numpy as np
import pytest

from pg_core.heightmap import Heightmap, world_to_pixel
from pg_learning.environment.sim_env import SimEnv
from pg_learning.evaluation.report import markdown
from pg_learning.evaluation.runner import EvalPlan, Limits, run_trial
from pg_learning.evaluation.target_by import centre_point, check_target_by, iou
from pg_policy.cli.main import main
from pg_policy.decision.decision import Decision
from pg_policy.policies.registry import make_policy
from pg_policy.target_loop.metrics import summarize, tracking
from pg_policy.target_loop.records import TrialRecord
from pg_sim.scenes.colors import resolve_color
from pg_sim.scenes.scene import ObjectSpec, SceneSpec

SEED = 1_000_000


def _grid(n: int = 50, resolution: float = 0.002) -> Heightmap:
    """An empty n x n heightmap of `resolution` m cells with its lower corner at (0, 0) in `world`."""
    bounds = np.array([[0.0, n * resolution], [0.0, n * resolution], [0.0, 0.3]])
    return Heightmap(np.zeros((n, n, 3), np.uint8), np.zeros((n, n), np.float32), np.ones((n, n), bool), resolution,
                     bounds)


def test_colour_targets_are_refused_where_colours_repeat(capsys, tmp_path):
    for colours in ("repeated", "same"):
        with pytest.raises(ValueError, match="--target-by colour cannot name the target"):
            check_target_by("colour", colours)
        with pytest.raises(ValueError, match="--target-by colour"):
            EvalPlan(("random-10",), 1, colours=colours)
    check_target_by("point", "same")
    check_target_by("colour", "unique")
    code = main(["eval", "--policy", "heuristic", "--scenes", "random-10", "--trials", "1", "--colours", "repeated",
                 "--out", str(tmp_path / "out"), "--no-progress"])
    assert code == 2
    assert "--target-by colour cannot name the target in scenes of --colours repeated" in capsys.readouterr().err
    assert not (tmp_path / "out").exists()


def test_centre_point_lies_on_the_mask_and_iou():
    hm = _grid()
    ring = np.zeros((50, 50), bool)
    ring[10:30, 10:30] = True
    ring[14:26, 14:26] = False  # hollow: the centroid is not the object's
    pt = centre_point(hm, ring)
    assert ring[world_to_pixel(pt.x, pt.y, hm.bounds, hm.resolution)]
    square = np.zeros((50, 50), bool)
    square[5:15, 20:30] = True
    pt = centre_point(hm, square)
    assert (pt.x, pt.y) == pytest.approx((0.05, 0.02))
    hm.height[square] = 0.02
    hm.height[8:12, 23:27] = 0.003  # a thin part at the centre: a point there would name bare table
    pt = centre_point(hm, square)
    row, col = world_to_pixel(pt.x, pt.y, hm.bounds, hm.resolution)
    assert square[row, col] and hm.height[row, col] == pytest.approx(0.02)
    pieces = np.zeros((50, 50), bool)
    pieces[20:26, 5:20], pieces[20:26, 30:40] = True, True  # a bar seen on both sides of an object across it
    hm.height[:] = 0.02
    pt = centre_point(hm, pieces)
    row, col = world_to_pixel(pt.x, pt.y, hm.bounds, hm.resolution)
    assert pieces[row - 2 : row + 3, col - 2 : col + 3].all() and col < 20  # inside the larger piece, not its rim
    half = np.roll(square, 5, axis=1)  # overlaps half of it
    assert iou(square, square) == 1.0 and iou(square, half) == pytest.approx(50 / 150)
    assert iou(np.zeros_like(square), np.zeros_like(square)) is None


def test_a_point_target_on_a_repeated_colour_scene_runs_and_records_iou_per_step():
    with SimEnv(colours="repeated") as env:
        rec = run_trial(env, make_policy("heuristic"), "random-10", SEED + 2, Limits(max_actions=3),
                        target_by="point")
        colours = [o.color for o in env.world.scene.objects]
        assert colours.count(env.world.scene.target_object.color) >= 2
    assert rec.error is None and rec.n_actions >= 1
    for a in rec.actions:
        view = a["target"]
        assert set(view) >= {"iou", "truth_cells", "unsure", "why", "visible", "cells"}
        assert view["iou"] is None or 0.0 <= view["iou"] <= 1.0
    assert rec.actions[0]["target"]["why"] == "first view" and rec.actions[0]["target"]["iou"] > 0.7
    t = tracking([rec])
    assert t.tracked == rec.n_actions and t.grasps == rec.grasps


class _GraspAt:
    """Grasps at a fixed point each time (a test double of a policy)."""

    name = "grasp-at"

    def __init__(self, x: float, y: float) -> None:
        self.x, self.y, self.masks = x, y, []

    def reset(self, seed=None):
        pass

    def act(self, obs):
        self.masks.append(obs.mask)
        return Decision("grasp", 0, 0, 0, 1.0, 0.0, self.x, self.y, 0.02, 1.0)


def test_grasping_another_object_of_the_targets_colour_is_a_failed_wrong_object_grasp():
    objs = (ObjectSpec("cube", None, resolve_color("green"), (0.06, -0.05, 0.0226, 0, 0, 0), target=True,
                       name="target"),
            ObjectSpec("cube", None, resolve_color("blue"), (-0.06, 0.05, 0.0226, 0, 0, 0), name="twin"))
    policy = _GraspAt(-0.06, 0.05)
    with SimEnv(colours="same") as env:
        rec = run_trial(env, policy, SceneSpec("two", "green", objs, "test"), SEED, Limits(max_actions=2),
                        target_by="mask")
    assert rec.actions[0]["outcome"]["grasped_color"] is not None and not rec.actions[0]["outcome"]["target_grasped"]
    assert not rec.completed and rec.failed_grasps >= 1 and rec.wrong_grasps >= 1 and rec.target_grasps == 0
    assert policy.masks[0] is not None and policy.masks[0].sum() > 100  # the policy got the tracked mask
    assert rec.actions[0]["target"]["iou"] == pytest.approx(1.0, abs=0.1)

    config = {"policy": "grasp-at", "seed": SEED, "trials": 1, "target_by": "mask", "colours": "same"}
    text = markdown(summarize([rec]), config, [rec])
    assert "| IoU ≥ 0.7 (% steps) | wrong object (% grasps) |" in text
    assert f"| {100 * rec.wrong_grasps // rec.grasps} ({rec.wrong_grasps}/{rec.grasps}) |" in text
    plain = markdown(summarize([rec]), {"policy": "grasp-at", "seed": SEED, "trials": 1}, [rec])
    assert "IoU" not in plain and "wrong object" not in plain and "| Scene | C (%) | GS (%) | MN |" in plain


def test_wrong_grasps_count_only_executed_grasps_that_held_another_object():
    def action(primitive, refused=False, target=False, colour=None):
        return {"outcome": {"primitive": primitive, "refused": refused, "target_grasped": target,
                            "grasped_color": colour}}

    rec = TrialRecord("s", 1, actions=[action("grasp", colour="red"), action("grasp"), action("push"),
                                       action("grasp", refused=True), action("grasp", target=True, colour="red"),
                                       {"outcome": None}])
    assert rec.wrong_grasps == 1
    assert "wrong_grasps" not in rec.to_dict()  # derived from the outcomes: the records' JSON is unchanged
