"""pg_learning.evaluation.track_figure draws the evaluation's own trial: for a fixed scene, the scene jittered from
the trial's seed as `pushgrasp eval` builds it, so the figure's first decision is the record's."""

from __future__ import annotations

from pathlib import Path

from pg_learning.environment.sim_env import SimEnv
from pg_learning.evaluation import track_figure
from pg_learning.evaluation.runner import EvalPlan, run_fresh
from pg_policy.policies.registry import make_policy
from pg_policy.target_loop.episode import Limits


def test_the_figure_replays_the_evaluation_trial_of_its_seed(tmp_path: Path, monkeypatch):
    scene, seed = "packed/case02", 1000006
    plan = EvalPlan(scenes=(scene,), trials=1, limits=Limits(max_actions=1), target_by="point", colours="repeated")
    rec = run_fresh(lambda: SimEnv(colours="repeated"), make_policy("lite"), scene, seed, plan)
    drawn = []
    monkeypatch.setattr(track_figure, "draw", lambda frames, *args: drawn.extend(frames))
    track_figure.main(["--scenes", scene, "--seed", str(seed), "--colours", "repeated", "--target-by", "point",
                       "--max-actions", "1", "--out", str(tmp_path / "fig.png")])
    d = rec.actions[0]["decision"]
    assert len(drawn) == 1 and drawn[0].decision[:3] == (d["primitive"], d["row"], d["col"])
