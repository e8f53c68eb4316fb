"""The evaluation runner: the protocol (DESIGN.md section 8) with a fake environment and scripted policies, plus one
real short `pushgrasp eval` run of the heuristic through the CLI."""

from __future__ import annotations

import json
import math
from dataclasses import dataclass

import numpy as np
import pytest

from pg_core.cpu_kernels import kernels_in_effect
from pg_learning.environment.sim_env import StepResult
from pg_learning.evaluation.runner import Limits, check_seed, expand_scenes, jitter_scene, run_trial
from pg_policy.cli.main import main
from pg_policy.decision.decision import Decision


@dataclass
class _Obs:
    step: int


class FakeEnv:
    """Outcome of each primitive scripted: `grasp_ok(n)` says whether the n-th (0-based) executed grasp holds the
    target; `refuse` lists primitives that are always refused."""

    def __init__(self, grasp_ok=lambda n: False, refuse: tuple[str, ...] = ()) -> None:
        self.grasp_ok, self.refuse = grasp_ok, refuse
        self.n_grasps, self.steps, self.resets = 0, 0, []

    def reset(self, scene, seed=0):
        self.resets.append((scene, seed))
        self.n_grasps = self.steps = 0
        return _Obs(0)

    def observe(self):
        return _Obs(self.steps)

    def step(self, primitive, x, y, z, yaw):
        self.steps += 1
        if primitive in self.refuse:
            return StepResult(primitive, False, True, False, False, None, "refused: unreachable", 0.0)
        if primitive == "push":
            return StepResult("push", True, False, False, False, None, "pushed", 1.0)
        ok = self.grasp_ok(self.n_grasps)
        self.n_grasps += 1
        return StepResult("grasp", True, False, ok, ok, "green" if ok else None, "grasped" if ok else "missed", 2.0)


class Scripted:
    """Returns the primitives of `script` in turn (the last one repeats)."""

    name = "scripted"

    def __init__(self, script: list[str]) -> None:
        self.script, self.i, self.seeds = script, 0, []

    def reset(self, seed=None):
        self.i = 0
        self.seeds.append(seed)

    def act(self, obs):
        prim = self.script[min(self.i, len(self.script) - 1)]
        self.i += 1
        return Decision(prim, 3, 10, 20, 0.5, 3 * math.pi / 8, 0.01, -0.02, 0.02, float("nan"))


def test_trial_stops_after_five_failed_grasps():
    env, pol = FakeEnv(), Scripted(["push", "grasp"])
    rec = run_trial(env, pol, "s", 1_000_007)
    assert (rec.termination, rec.completed) == ("failed_grasps", False)
    assert (rec.grasps, rec.failed_grasps, rec.pushes, rec.n_actions) == (5, 5, 1, 6)
    assert env.resets == [("s", 1_000_007)] and pol.seeds == [1_000_007]
    assert rec.actions[1]["decision"]["grasp_q"] is None  # NaN is written as null
    assert rec.actions[1]["outcome"]["message"] == "missed"


def test_trial_stops_at_the_action_budget_and_refusals_count_as_actions():
    rec = run_trial(FakeEnv(), Scripted(["push"]), "s", 0)
    assert (rec.termination, rec.n_actions, rec.pushes, rec.grasps) == ("max_actions", 30, 30, 0)
    rec = run_trial(FakeEnv(refuse=("grasp",)), Scripted(["grasp"]), "s", 0, Limits(max_actions=7))
    assert (rec.termination, rec.n_actions, rec.refused, rec.grasps, rec.failed_grasps) == ("max_actions", 7, 7, 0, 0)
    assert rec.grasp_success is None


def test_trial_completes_when_the_target_is_grasped():
    env = FakeEnv(grasp_ok=lambda n: n == 1)
    rec = run_trial(env, Scripted(["push", "push", "grasp"]), "s", 0)
    assert (rec.termination, rec.completed) == ("completed", True)
    assert (rec.pushes, rec.grasps, rec.target_grasps, rec.failed_grasps, rec.n_actions) == (2, 2, 1, 1, 4)
    assert rec.grasp_success == 0.5 and rec.sim_s == pytest.approx(6.0)
    # the target grasped on the very last allowed action still completes the trial
    rec = run_trial(FakeEnv(grasp_ok=lambda n: True), Scripted(["push", "push", "grasp"]), "s", 0, Limits(3, 5))
    assert rec.completed and rec.n_actions == 3


def test_seed_policy_and_scene_expansion():
    check_seed(1_000_000)
    with pytest.raises(ValueError, match="training"):
        check_seed(999_999)
    check_seed(5, allow_train_seeds=True)
    packed = expand_scenes(["packed"])
    assert packed == [f"packed/case{i:02d}" for i in range(1, 10)]
    assert expand_scenes(["household", "random-10"])[-1] == "random-10" and len(expand_scenes(["household"])) == 4
    assert expand_scenes(["dense-8"]) == ["dense-8"]
    with pytest.raises(ValueError, match="packed/case01"):
        expand_scenes(["packed/case1"])
    with pytest.raises(ValueError, match="at least one object"):
        expand_scenes(["dense-0"])


def test_jitter_moves_the_scene_rigidly_and_reproducibly():
    from pg_sim.scenes.scene import load_scene

    scene = load_scene("packed/case03")
    a = jitter_scene(scene, np.random.default_rng(3), 0.01, 0.2)
    b = jitter_scene(scene, np.random.default_rng(3), 0.01, 0.2)
    assert a == b and a != scene
    assert jitter_scene(scene, np.random.default_rng(3), 0.0, 0.0) is scene

    def dists(s):
        xy = np.array([o.pose[:2] for o in s.objects])
        return np.linalg.norm(xy[:, None] - xy[None], axis=-1)

    np.testing.assert_allclose(dists(a), dists(scene), atol=1e-9)
    dyaw = [(o2.pose[5] - o1.pose[5] + math.pi) % (2 * math.pi) - math.pi
            for o1, o2 in zip(scene.objects, a.objects, strict=True)]
    assert np.ptp(dyaw) < 1e-9 and abs(dyaw[0]) <= 0.2


def test_cli_errors(tmp_path, capsys):
    assert main(["eval", "--policy", "nope", "--scenes", "packed/case01", "--trials", "1", "--out", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert "unknown policy 'nope'" in err and "heuristic" in err and "learned" in err
    assert main(["eval", "--policy", "heuristic", "--scenes", "packed/case99", "--trials", "1", "--out",
                 str(tmp_path)]) == 2
    assert "packed/case99" in capsys.readouterr().err
    assert main(["eval", "--policy", "learned", "--model", str(tmp_path / "missing"), "--scenes", "packed/case01",
                 "--trials", "1", "--out", str(tmp_path)]) == 2
    assert "not found" in capsys.readouterr().err
    assert main(["eval", "--policy", "heuristic", "--scenes", "packed/case01", "--trials", "1", "--seed", "3",
                 "--out", str(tmp_path)]) == 2
    assert "--allow-train-seeds" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        main(["eval", "--policy", "heuristic", "--scenes", "packed/case01", "--trials", "1", "--sim-mode", "quick",
              "--out", str(tmp_path)])
    assert "invalid choice: 'quick'" in capsys.readouterr().err
    assert not (tmp_path / "results.json").exists()


def test_the_faithful_mode_reaches_the_trials_environment(tmp_path):
    out = tmp_path / "ev"
    assert main(["eval", "--policy", "heuristic", "--scenes", "packed/case01", "--trials", "1", "--out", str(out),
                 "--sim-mode", "faithful", "--max-actions", "1", "--no-progress"]) == 0
    doc = json.loads((out / "results.json").read_text())
    assert doc["config"]["sim_mode"] == "faithful"
    assert doc["trials"][0]["sim_s"] > 3.0  # every motion stepped (fast: the free-space moves are teleports)


def test_cli_heuristic_on_packed_case01(tmp_path, capsys):
    out = tmp_path / "ev"
    assert main(["eval", "--policy", "heuristic", "--scenes", "packed/case01", "--trials", "2", "--out", str(out),
                 "--no-progress"]) == 0
    assert {p.name for p in out.iterdir()} == {"results.json", "results.md", "results.png", "trials.jsonl"}
    doc = json.loads((out / "results.json").read_text())
    assert doc["config"]["policy"] == "heuristic" and doc["config"]["seed"] == 1_000_000
    assert doc["config"]["sim_mode"] == "fast"
    assert doc["config"]["cpu_kernels"] == kernels_in_effect()  # the suite pins them (conftest): "pinned" on x86-64
    assert [t["seed"] for t in doc["trials"]] == [1_000_000, 1_000_001]
    for t in doc["trials"]:
        assert t["scene"] == "packed/case01" and t["n_actions"] == len(t["actions"]) >= 1
        assert t["termination"] in ("completed", "failed_grasps", "max_actions")
        a = t["actions"][0]
        assert a["decision"]["primitive"] in ("grasp", "push") and "target_grasped" in a["outcome"]
    assert set(doc["summary"]["packed/case01"]) >= {"C", "GS", "MN"}
    md = (out / "results.md").read_text().splitlines()
    head = md.index("| Scene | C (%) | GS (%) | MN |")
    assert md[head + 1] == "|---|---|---|---|"
    row = md[head + 2].split("|")
    assert row[1].strip() == "packed/case01" and all("±" in cell for cell in row[2:4])
    assert "| packed/case01 |" in capsys.readouterr().out


@pytest.mark.parametrize(("workers", "cpus", "threads"), [(2, 2, 1), (16, 16, 1), (4, 16, 4), (3, 2, 1), (0, 8, 8)])
def test_eval_workers_share_the_cpus_out(workers, cpus, threads):
    from pg_learning.evaluation.trial_workers import worker_threads

    assert worker_threads(workers, cpus) == threads
