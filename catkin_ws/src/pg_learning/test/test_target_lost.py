"""target_lost end to end: a target pushed out of the workspace in the simulator ends the trial as target_lost within
two actions (with the simulator's ground truth, and on the target memory's evidence alone, as on a real cell), and
records with target_lost load and show in the report."""

from __future__ import annotations

import json
import math
from typing import Any

from pg_core.heightmap import rotation_yaw
from pg_learning.evaluation.journal import record_from_dict
from pg_learning.evaluation.report import write_results
from pg_learning.evaluation.runner import run_trial
from pg_learning.evaluation.saved_runs import load_trials
from pg_policy.decision.decision import Decision
from pg_policy.target_loop.records import TrialRecord

EDGE_X = 0.19  # the target cube's centre: 5 cells of the heightmap from its +x border (x max 0.224 m)


def edge_scene() -> Any:
    from pg_sim.scenes.colors import resolve_color
    from pg_sim.scenes.scene import ObjectSpec, SceneSpec

    objs = (ObjectSpec("cube", None, resolve_color("green"), (EDGE_X, 0.0, 0.0226, 0, 0, 0), target=True,
                       name="target"),
            ObjectSpec("rect", None, resolve_color("blue"), (-0.1, 0.1, 0.0226, 0, 0, 1.0), name="other"))
    return SceneSpec("edge", "green", objs, "test")


class PushOut:
    """First a push along +x from behind the target (it leaves the workspace: the push end is clipped to the
    workspace, the fingers carry the cube beyond it), then pushes on empty table far away, each at a new rotation."""

    name = "push-out"

    def reset(self, seed: int | None = None) -> None:
        self.n = 0

    def act(self, obs: Any) -> Decision:
        self.n += 1
        if self.n == 1:
            return Decision("push", 0, 112, 182, math.nan, 0.0, EDGE_X - 0.05, 0.0, 0.01, math.nan)
        r = self.n % 16
        return Decision("push", r, 37, 37, math.nan, rotation_yaw(r, 16), -0.15, -0.15, 0.005, math.nan)


class NoGroundTruth:
    """A SimEnv seen as a real cell: no target_outside()."""

    def __init__(self, env: Any) -> None:
        self.env = env

    def reset(self, scene: Any, seed: int = 0) -> Any:
        return self.env.reset(scene, seed)

    def step(self, *args: Any) -> Any:
        return self.env.step(*args)

    def observe(self) -> Any:
        return self.env.observe()


def test_a_target_pushed_out_of_the_workspace_ends_the_trial_as_target_lost():
    from pg_learning.environment.sim_env import SimEnv

    with SimEnv() as env:
        rec = run_trial(env, PushOut(), edge_scene(), 0, scene_name="edge")
        assert env.target_outside()
    assert (rec.termination, rec.completed, rec.n_actions) == ("target_lost", False, 1), rec.message
    assert rec.message.startswith("target lost: ") and "simulator" in rec.message
    assert rec.actions[0]["target"]["visible"] and rec.pushes == 1

    with SimEnv() as env:  # the evidence alone: last seen at the edge, then hidden for two observations
        rec = run_trial(NoGroundTruth(env), PushOut(), edge_scene(), 0, scene_name="edge")
    assert (rec.termination, rec.n_actions) == ("target_lost", 2), rec.message
    assert rec.message.startswith("target lost: hidden for 2 actions since last seen at the workspace edge")


def test_target_lost_records_load_and_show_in_the_report(tmp_path):
    lost = TrialRecord("random-10", 1_000_001, False, "target_lost", 1, 0, 1, 3, 0, [{}] * 4,
                       message="target lost: seen leaving the workspace at (0.210, 0.004)")
    done = TrialRecord("random-10", 1_000_000, True, "completed", 1, 1, 0, 1, 0, [{}] * 2)
    old = done.to_dict()
    del old["message"]  # a record saved before the field existed
    assert record_from_dict(old).message == "" and record_from_dict(lost.to_dict()) == lost
    paths = write_results(tmp_path, [record_from_dict(old), lost], {"policy": "x", "seed": 1_000_000, "trials": 2})
    md = paths["md"].read_text()
    assert "**1 of 2 trials lost the target**" in md
    assert "- random-10: 1 × (seed 1000001: target lost: seen leaving the workspace at (0.210, 0.004))" in md
    assert "| random-10 | 2 | 1 | 0 | 1 |" in md and "| 0 / 0 / 1 / 0 |" in md
    doc = json.loads(paths["json"].read_text())
    assert doc["summary"]["random-10"]["counts"] == {"trials": 2, "completed": 1, "errors": 0, "lost": 1,
                                                          "not_found": 0}
    assert doc["summary"]["random-10"]["lost"]["mean"] == 0.5 and doc["summary"]["random-10"]["C"]["mean"] == 0.5
    assert [t.termination for t in load_trials(tmp_path)] == ["completed", "target_lost"]
