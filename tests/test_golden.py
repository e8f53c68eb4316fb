"""Golden decisions of the shipped policy: the redesigns of the code must not change what it decides.

tests/golden/ holds every observation the shipped `lite` policy saw in the first protocol trial (seed 1,000,000) of
each of the 16 protocol scenes, with the decision it took (recorded by tests/golden/record_golden.py, one torch thread
as in a protocol worker). The replay feeds the stored heightmaps through a fresh policy trial by trial, each through
the episode protocol's target memory as an evaluation trial does (pg_policy.target_loop.episode), so the within-trial
rules (failed grasps, futile pushes) and the memory see the same history; the simulator test re-runs two of those
trials end to end and must take the same actions as long as the simulator reproduces the recorded observations.
"""

from __future__ import annotations

import json
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from types import SimpleNamespace
from typing import Any

import numpy as np
import pytest

GOLDEN = Path(__file__).resolve().parent / "golden"
SEED = 1_000_000


@contextmanager
def one_thread() -> Iterator[None]:
    import cv2
    import torch

    before = torch.get_num_threads(), cv2.getNumThreads()
    torch.set_num_threads(1)
    cv2.setNumThreads(1)
    try:
        yield
    finally:
        torch.set_num_threads(before[0])
        cv2.setNumThreads(before[1])


def records() -> list[dict[str, Any]]:
    return json.loads((GOLDEN / "decisions.json").read_text())


def assert_same(decision: Any, want: dict[str, Any], where: str) -> None:
    got = (decision.primitive, int(decision.rotation), int(decision.row), int(decision.col))
    assert got == (want["primitive"], want["rotation"], want["row"], want["col"]), f"{where}: {got} != {want}"
    np.testing.assert_allclose([decision.q, decision.grasp_q], [want["q"], want["grasp_q"]], rtol=1e-5, atol=1e-6,
                               err_msg=where)


def legacy_copy(folder: Path) -> Path:
    """The shipped model re-exported with the metadata of models exported before rule lists existed: the decision
    switches under `thresholds`, no `rules` (weights unchanged)."""
    from pg_policy.models.model_io import export_qnet, load_qnet
    from pg_policy.policies.model_files import SHIPPED_MODELS

    for role in ("grasp", "push"):
        net, meta = load_qnet(SHIPPED_MODELS / "lite" / f"{role}.pt")
        del meta["rules"]
        meta["thresholds"].update(grasp_filter="min3", grasp_check="jaw-walls", push_landing=True, edge_guard=True)
        export_qnet(net, folder / f"{role}.pt", meta)
    return folder


@pytest.mark.parametrize("model", ["lite", "lite with legacy metadata"])
def test_golden_replay_of_every_protocol_scene(model: str, tmp_path: Path) -> None:
    from pg_core.heightmap import Heightmap
    from pg_core.target_mask import target_mask
    from pg_policy.policies.registry import make_policy
    from pg_policy.target_loop.episode import Episode, Outcome

    arrays = np.load(GOLDEN / "decisions.npz")
    recs = records()
    assert len({r["scene"] for r in recs}) == 16
    with one_thread():
        policy = make_policy("lite" if model == "lite" else str(legacy_copy(tmp_path)))
        for k, rec in enumerate(recs):
            if rec["step"] == 0:
                policy.reset(rec["seed"])
                episode = Episode()
            hm = Heightmap(arrays[f"color_{k}"], arrays[f"height_{k}"], arrays[f"valid_{k}"], rec["resolution"],
                           np.asarray(rec["bounds"]))
            search = episode.observe(hm, target_mask(hm.color, hm.valid, rec["target"]))
            d = policy.act(SimpleNamespace(heightmap=hm, target=rec["target"], search=search))
            assert_same(d, rec["decision"], f"{rec['scene']} step {rec['step']}")
            assert str(getattr(policy, "last_note", "")) == rec["note"]
            assert episode.vet(d) is None  # the protocol executes it (no futile push repeated)
            episode.record(d, Outcome())  # executed; the trial went on unless this was its last action


@pytest.mark.parametrize("scene", ["packed/case01", "random-10"])
def test_first_protocol_trial_in_the_simulator(scene: str) -> None:
    """The trial end to end (scene reset, observation, policy, primitives). The recording holds one machine's
    physics: another CPU's floating point (BLAS kernels, libm) moves the objects differently once the gripper touches
    them, so the decisions are compared for every step whose observation the simulator reproduces exactly, at least
    the first; the recorded outcome is required when the whole trial is reproduced."""
    from functools import partial

    from pg_learning.environment.sim_env import SimEnv
    from pg_learning.evaluation.runner import EvalPlan, run_fresh
    from pg_policy.policies.registry import make_policy

    recs = records()
    index = [k for k, r in enumerate(recs) if r["scene"] == scene]
    arrays = np.load(GOLDEN / "decisions.npz")
    seen: list[Any] = []
    with one_thread():
        # recorded in the faithful simulation mode (every motion stepped)
        policy = make_policy("lite")
        act = policy.act

        def observing(obs: Any) -> Any:
            seen.append(obs.heightmap)
            return act(obs)

        policy.act = observing  # type: ignore[method-assign]
        env = partial(SimEnv, sim_mode="faithful")
        trial = run_fresh(env, policy, scene, SEED, EvalPlan(scenes=(scene,), trials=1, seed=SEED))
    assert trial.error is None, trial.error
    reproduced = 0
    for hm, a, k in zip(seen, trial.actions, index, strict=False):
        if not (np.array_equal(hm.height, arrays[f"height_{k}"]) and np.array_equal(hm.color, arrays[f"color_{k}"])):
            break
        assert_same(SimpleNamespace(**a["decision"]), recs[k]["decision"], f"{scene} step {recs[k]['step']}")
        reproduced += 1
    assert reproduced >= 1, f"{scene}: the first observation differs from the recorded one"
    if reproduced == len(index):
        assert trial.completed and len(trial.actions) == len(index)
