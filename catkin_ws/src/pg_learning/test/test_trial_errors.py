"""DESIGN.md section 8: "An error inside a trial (policy or simulator) ends that trial as a failure with its reason; the
run goes on." Fake environments and policies that raise at each stage of a trial, the worker pool with jobs that
raise and workers that die, the written results, and `pushgrasp eval` end to end with a plugin policy that raises
(serially and with --workers 2, a worker process dying too)."""

from __future__ import annotations

import json
import math
import os
import textwrap

import pytest

from pg_learning.environment.sim_env import StepResult
from pg_learning.evaluation.errors import ERROR_CHARS, describe
from pg_learning.evaluation.ray_trials import run_on_ray
from pg_learning.evaluation.report import write_results
from pg_learning.evaluation.runner import EvalPlan, Limits, run_plan, run_trial
from pg_policy.cli.main import main
from pg_policy.decision.decision import Decision
from pg_policy.target_loop.metrics import scene_metrics, summarize
from pg_policy.target_loop.records import TrialRecord


class Env:
    """Pushes always succeed, grasps always miss; `fail` names the method that raises (on `fail_seed` only)."""

    def __init__(self, fail: str = "", fail_seed: int | None = None) -> None:
        self.fail, self.fail_seed, self.seed, self.steps, self.closed = fail, fail_seed, None, 0, False

    def _maybe(self, what: str) -> None:
        if what == self.fail and self.fail_seed in (None, self.seed):
            raise RuntimeError(f"simulator broke in {what}")

    def reset(self, scene, seed=0):
        self.seed, self.steps = seed, 0
        self._maybe("reset")
        return self.steps

    def observe(self):
        self._maybe("observe")
        return self.steps

    def step(self, primitive, x, y, z, yaw):
        self.steps += 1
        if self.steps == 2:
            self._maybe("step")
        if primitive == "push":
            return StepResult("push", True, False, False, False, None, "pushed", 1.0)
        return StepResult("grasp", True, False, False, False, None, "missed", 2.0)

    def close(self):
        self.closed = True


class Policy:
    """Push, grasp, push, grasp, ...; act() raises on its `raise_at`-th call (1-based) of the trial of `fail_seed`."""

    name = "flaky"

    def __init__(self, fail_seed: int | None = None, raise_at: int = 3, fail_reset: bool = False,
                 exc: BaseException | None = None) -> None:
        self.fail_seed, self.raise_at, self.fail_reset = fail_seed, raise_at, fail_reset
        self.exc = exc or ValueError("zero-size array to reduction operation minimum which has no identity")
        self.seed, self.calls = None, 0

    def reset(self, seed=None):
        self.seed, self.calls = seed, 0
        if self.fail_reset and seed == self.fail_seed:
            raise KeyError("no model for this seed")

    def act(self, obs):
        self.calls += 1
        if self.seed == self.fail_seed and self.calls == self.raise_at:
            raise self.exc
        prim = "push" if self.calls % 2 else "grasp"
        return Decision(prim, 0, 1, 2, 0.5, 0.0, 0.01, -0.02, 0.02, math.nan)


def _plan(trials=3, scenes=("random-5",), max_actions=6):
    return EvalPlan(tuple(scenes), trials, 1_000_000, Limits(max_actions, 5))


def test_an_exception_in_act_ends_only_that_trial_as_an_error():
    envs: list[Env] = []

    def make_env():
        envs.append(Env())
        return envs[-1]

    seen: list[TrialRecord] = []
    recs = run_plan(make_env, Policy(fail_seed=1_000_001), _plan(), on_trial=seen.append)
    assert len(recs) == 3 and seen == recs and all(e.closed for e in envs)
    assert [r.termination for r in recs] == ["max_actions", "error", "max_actions"]
    bad = recs[1]
    assert (bad.completed, bad.error_at, bad.seed) == (False, "policy.act", 1_000_001)
    assert bad.error == "ValueError: zero-size array to reduction operation minimum which has no identity"
    assert "in act" in bad.error_trace and "raise self.exc" in bad.error_trace
    # the two actions before the error are kept and counted
    assert (bad.n_actions, bad.pushes, bad.grasps, bad.failed_grasps) == (2, 1, 1, 1)
    assert [a["decision"]["primitive"] for a in bad.actions] == ["push", "grasp"]
    assert recs[0].error is None and recs[0].error_at is None
    m = scene_metrics(recs)
    assert (m["C"].mean, m["C"].n) == (0.0, 3) and m["errors"].mean == pytest.approx(1 / 3) and m["errors"].n == 3
    assert m["GS"].n == 3  # its grasp attempt counts
    d = bad.to_dict()
    assert d["termination"] == "error" and d["error"].startswith("ValueError") and d["error_at"] == "policy.act"


@pytest.mark.parametrize(("env_fail", "policy_kw", "stage", "kept"), [
    ("reset", {}, "env.reset", 0),
    ("step", {}, "env.step", 1),
    ("observe", {}, "env.observe", 1),
    ("", {"fail_reset": True}, "policy.reset", 0),
])
def test_every_stage_of_a_trial_is_caught(env_fail, policy_kw, stage, kept):
    rec = run_trial(Env(env_fail), Policy(fail_seed=7, **policy_kw), "s", 7)
    assert (rec.termination, rec.completed, rec.error_at, rec.n_actions) == ("error", False, stage, kept)
    assert rec.error.split(":")[0] in ("RuntimeError", "KeyError") and rec.wall_s > 0


def test_building_the_scene_or_the_simulator_fails_as_an_error_too():
    recs = run_plan(Env, Policy(), _plan(1, scenes=("packed/case99", "random-5")))
    assert [r.error_at for r in recs] == ["scene", None] and "packed/case99" in recs[0].error

    def no_sim():
        raise OSError("cannot connect to the physics server")

    recs = run_plan(no_sim, Policy(), _plan(2))
    assert [(r.termination, r.error_at) for r in recs] == [("error", "env.make")] * 2
    assert recs[0].error == "OSError: cannot connect to the physics server"


def test_keyboard_interrupt_still_stops_the_run():
    with pytest.raises(KeyboardInterrupt):
        run_plan(Env, Policy(fail_seed=1_000_000, raise_at=1, exc=KeyboardInterrupt()), _plan())


def test_error_text_is_one_line_and_cut():
    text = describe(RuntimeError("x" * 1000 + "\nsecond line"))
    assert len(text) == ERROR_CHARS and text.startswith("RuntimeError: xxx") and text.endswith("...")
    assert describe(ValueError("a\n  b")) == "ValueError: a b" and describe(KeyError()) == "KeyError"


def test_results_count_and_list_the_errors(tmp_path):
    recs = run_plan(Env, Policy(fail_seed=1_000_001), _plan(3, scenes=("random-5", "random-6")))
    recs += run_plan(Env, Policy(fail_seed=1_000_000), _plan(1, scenes=("random-6",)))
    assert summarize(recs)["random-6"]["errors"].mean == pytest.approx(0.5)
    out = tmp_path / "ev"
    paths = write_results(out, recs, {"policy": "flaky", "seed": 1_000_000, "trials": 3})
    doc = json.loads(paths["json"].read_text())
    assert doc["summary"]["random-6"]["counts"] == {"trials": 4, "completed": 0, "errors": 2, "lost": 0,
                                                      "not_found": 0}
    assert doc["summary"]["all"]["counts"]["errors"] == 3 and doc["summary"]["random-5"]["errors"]["n"] == 3
    reason = "policy.act: ValueError: zero-size array to reduction operation minimum which has no identity"
    assert doc["errors"] == [{"reason": reason, "count": 3, "trials": [["random-5", 1_000_001],
                                                                      ["random-6", 1_000_001],
                                                                      ["random-6", 1_000_000]]}]
    assert [t["termination"] for t in doc["trials"]].count("error") == 3
    md = paths["md"].read_text()
    printed = md.split("\n\nC: ")[0]  # what `pushgrasp eval` prints
    assert "**3 of 7 trials ended in an error**" in printed and f"- 3 × {reason} (random-5 seed 1000001" in printed
    assert "| random-6 | 4 | 0 | 2 |" in md


# -- the worker pool: jobs are module functions so that spawned workers can import them --------------------------
DIE, RAISE = 11, 12


def _init(die: bool = False) -> None:
    if die:
        os._exit(7)


def _trial(index, name, seed, plan):
    if seed == DIE:
        os._exit(9)  # the worker process dies: no exception, no record
    if seed == RAISE:
        raise RuntimeError("record lost on the way back")
    return index, TrialRecord(name, seed, True, "completed", 1, 1, 0, 0, 0, [{}])


def test_ray_keeps_finished_trials_when_a_worker_dies_or_a_job_raises(importable_here):
    jobs = [("a", s) for s in (10, DIE, RAISE, 13, 14, 15)]
    seen: list[TrialRecord] = []
    recs = run_on_ray(jobs, None, 2, _trial, _init, (), seen.append)
    assert [r.seed for r in recs] == [10, DIE, RAISE, 13, 14, 15] and len(seen) == 6
    assert [r.termination for r in recs] == ["completed", "error", "error", "completed", "completed", "completed"]
    assert recs[1].error_at == "worker" and recs[1].error.startswith("process died running this trial")
    assert (recs[2].error_at, recs[2].error) == ("worker", "RuntimeError: record lost on the way back")


def test_ray_whose_workers_cannot_start_ends_every_trial_as_an_error(importable_here):
    recs = run_on_ray([("a", s) for s in (1, 2, 3)], None, 2, _trial, _init, (True,))
    assert [r.termination for r in recs] == ["error"] * 3
    assert all(r.error.startswith("process died before starting its trial") for r in recs)


# -- `pushgrasp eval` end to end with a plugin policy that raises ---------------------------------------------------
PLUGIN = '''
import os

from pg_policy.policies.heuristic import HeuristicPolicy


class RaisingPolicy(HeuristicPolicy):
    """The heuristic, but its second act() of the trial of seed $PG_TEST_RAISE_SEED raises and any act() of the
    trial of seed $PG_TEST_DIE_SEED kills the process."""

    name = "test-raising"

    def reset(self, seed=None):
        super().reset(seed)
        self.trial_seed, self.calls = seed, 0

    def act(self, obs):
        self.calls += 1
        if str(self.trial_seed) == os.environ.get("PG_TEST_DIE_SEED"):
            os._exit(9)
        if str(self.trial_seed) == os.environ.get("PG_TEST_RAISE_SEED") and self.calls == 2:
            raise ValueError("zero-size array to reduction operation minimum which has no identity")
        return super().act(obs)
'''


@pytest.fixture
def raising_plugin(tmp_path, monkeypatch):
    """The policy `test-raising`, registered as an installed plugin on sys.path and on the PYTHONPATH of Ray's
    workers."""
    site = tmp_path / "site"
    info = site / "pg_test_raising-0.1.dist-info"
    info.mkdir(parents=True)
    (site / "pg_test_raising.py").write_text(textwrap.dedent(PLUGIN))
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: pg-test-raising\nVersion: 0.1\n")
    (info / "entry_points.txt").write_text("[pushgrasp.policies]\ntest-raising = pg_test_raising:RaisingPolicy\n")
    monkeypatch.syspath_prepend(str(site))
    monkeypatch.setenv("PYTHONPATH", os.pathsep.join(p for p in (str(site), os.environ.get("PYTHONPATH")) if p))
    monkeypatch.setenv("PG_TEST_RAISE_SEED", "1000001")
    return tmp_path


def _eval(out, *extra):
    return main(["eval", "--policy", "test-raising", "--scenes", "packed/case01", "--trials", "3", "--max-actions",
                 "2", "--out", str(out), "--no-progress", *extra])


def _check_raised(doc):
    t = doc["trials"][1]
    assert (t["seed"], t["termination"], t["completed"], t["error_at"]) == (1_000_001, "error", False, "policy.act")
    assert t["error"] == "ValueError: zero-size array to reduction operation minimum which has no identity"
    assert t["n_actions"] == len(t["actions"]) == 1  # the first action was taken before act() raised


def test_cli_eval_records_a_raising_policy_and_writes_the_results(raising_plugin, capsys):
    out = raising_plugin / "ev"
    assert _eval(out) == 0
    assert {p.name for p in out.iterdir()} == {"results.json", "results.md", "results.png", "trials.jsonl"}
    doc = json.loads((out / "results.json").read_text())
    assert [t["seed"] for t in doc["trials"]] == [1_000_000, 1_000_001, 1_000_002]
    _check_raised(doc)
    assert all(t["termination"] != "error" and t["error"] is None for t in doc["trials"][::2])
    assert doc["summary"]["packed/case01"]["counts"]["errors"] == 1 and doc["errors"][0]["count"] == 1
    assert doc["summary"]["packed/case01"]["C"]["n"] == 3
    captured = capsys.readouterr()
    assert "1 of 3 trials ended in an error" in captured.out
    assert "- 1 × policy.act: ValueError: zero-size array" in captured.out and "seed 1000001" in captured.out


def test_cli_eval_with_workers_survives_a_raise_and_a_dying_worker(raising_plugin, monkeypatch):
    monkeypatch.setenv("PG_TEST_DIE_SEED", "1000002")
    out = raising_plugin / "ev2"
    assert _eval(out, "--workers", "2") == 0
    doc = json.loads((out / "results.json").read_text())
    assert [t["seed"] for t in doc["trials"]] == [1_000_000, 1_000_001, 1_000_002]
    _check_raised(doc)
    assert doc["trials"][0]["termination"] in ("completed", "target_lost", "target_not_found", "failed_grasps",
                                                "max_actions")
    died = doc["trials"][2]
    assert (died["termination"], died["error_at"]) == ("error", "worker")
    assert died["error"].startswith("process died running this trial")
    assert doc["summary"]["packed/case01"]["counts"] == {"trials": 3, "completed": int(doc["trials"][0]["completed"]),
                                                         "errors": 2, "lost": 0, "not_found": 0}
