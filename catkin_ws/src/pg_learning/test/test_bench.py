"""Decision-latency benchmark: every speed-up mode against full-map inference, the table, the CLI."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from pg_core.geometry import load
from pg_core.heightmap import Heightmap
from pg_learning.evaluation.bench import MODES, Case, Decider, bench_variant
from pg_policy.cli.main import main
from pg_policy.models.inference import PolicyNets, target_window

torch.set_num_threads(2)


def _case(seed: int = 0, size: int = 112) -> Case:
    """A synthetic clutter heightmap (size x size cells, smaller than the real map to keep the test fast): random
    boxes on a table, the target one of them."""
    geo = load()
    rng = np.random.default_rng(seed)
    color = np.full((size, size, 3), (199, 178, 148), np.uint8)
    height = np.zeros((size, size), np.float32)
    target = np.zeros((size, size), bool)
    for i in range(8):
        r, c = rng.integers(10, size - 40, 2)
        h, w = rng.integers(10, 30, 2)
        color[r:r + h, c:c + w] = rng.integers(0, 255, 3)
        height[r:r + h, c:c + w] = rng.uniform(0.02, 0.06)
        if i == 7:
            target[:] = False
            target[r:r + h, c:c + w] = True
    bounds = geo.workspace.bounds.copy()
    bounds[:2, 1] = bounds[:2, 0] + size * geo.heightmap.resolution
    hm = Heightmap(color, height, np.ones_like(target), geo.heightmap.resolution, bounds)
    return Case(f"synthetic-{seed}", hm, target)


@pytest.fixture(scope="module")
def nets():
    return PolicyNets.random("lite", "mask", rotations=8, seed=0)


def test_target_window():
    mask = np.zeros((50, 60), bool)
    mask[10:20, 40:55] = True
    assert target_window(mask, 5) == (5, 25, 35, 60)
    assert target_window(np.zeros((4, 4), bool), 3) is None


@pytest.mark.parametrize("threshold", [-1e9, 1e9])  # the early grasp always / never fires
def test_modes_agree_with_full_map(nets, threshold):
    prims = load().primitives
    decider = Decider(nets, prims, threshold)
    for seed in (0, 1):
        case = _case(seed)
        ref = decider.batched(case.heightmap, case.target)
        assert ref.primitive == ("grasp" if threshold < 0 else "push")
        for mode in ("vpg-loop", "early-grasp", "window", "window+early"):
            d = MODES[mode](decider, case.heightmap, case.target)
            assert (d.primitive, d.rotation, d.row, d.col) == (ref.primitive, ref.rotation, ref.row, ref.col), mode
            assert d.x == pytest.approx(ref.x) and d.y == pytest.approx(ref.y) and d.q == pytest.approx(ref.q, abs=1e-4)
            assert d.z == pytest.approx(ref.z)  # every mode decides on the whole heightmap, as the policy does
    assert decider.early_fired == (4 if threshold < 0 else 0)


def test_the_bench_decides_as_the_learned_policy_without_rules(tmp_path):
    """Each mode's decision is the learned policy's own on the same nets with no test-time rules (same threshold, no
    push budget), given the target mask the policy finds."""
    from pg_core.palette import PALETTE
    from pg_core.target_mask import target_mask
    from pg_policy.models.model_io import export_qnet
    from pg_policy.models.nets import QNetConfig, build_qnet
    from pg_policy.policies.policy import PolicyOptions
    from pg_policy.policies.registry import make_policy
    from pg_policy.target_loop.loop_types import PolicyObservation

    for i, role in enumerate(("grasp", "push")):
        export_qnet(build_qnet(QNetConfig("lite", "mask"), seed=i), tmp_path / f"{role}.pt",
                    {"role": role, "thresholds": {"grasp_q": 0.0}})
    case = _case(0)
    hm = case.heightmap
    hm.color[:] = (199, 178, 148)  # the table's colour, the target green: the policy's own mask is the case's
    hm.color[case.target] = PALETTE["green"]
    target = target_mask(hm.color, hm.valid, "green")
    assert (target == case.target).all()
    for threshold in (-1e9, 1e9):
        policy = make_policy("learned", PolicyOptions(models=(tmp_path,), overrides={
            "rules": "none", "q_window": False, "grasp_threshold": threshold, "push_budget": 0}))
        policy.reset(0)
        theirs = policy.act(PolicyObservation(hm, "green"))
        assert theirs.primitive == ("grasp" if threshold < 0 else "push")
        decider = Decider(policy.nets, load().primitives, threshold)
        for mode in MODES.values():
            mine = mode(decider, hm, target)
            assert (mine.primitive, mine.rotation, mine.row, mine.col) == (
                theirs.primitive, theirs.rotation, theirs.row, theirs.col)
            assert mine.z == pytest.approx(theirs.z)


def test_bench_variant_rows_and_report(nets):
    from pg_learning.evaluation.bench import BenchResult

    cases = [_case(0), _case(1)]
    rows = bench_variant("lite", cases, runs=2, modes=("vpg-loop", "batched", "window"), threshold=1e9,
                         rotations=4)
    assert [r.mode for r in rows] == ["vpg-loop", "batched", "window"]
    assert all(r.median_ms > 0 and r.cpu_ms >= 0 and r.agree == 2 and r.cases == 2 for r in rows)
    assert rows[0].speedup == pytest.approx(1.0) and "exact" in rows[2].note
    text = BenchResult(rows, 2, 2, [c.name for c in cases], 1e9).report()
    assert "vs vpg-loop" in text and "100.0% (2/2)" in text and text.count("\nlite") == 3
    with pytest.raises(ValueError, match="unknown modes"):
        bench_variant("lite", cases, runs=1, modes=("fast",))


def test_cli_bench_on_a_shipped_scene(capsys):
    rc = main(["bench", "--variants", "lite", "--runs", "1", "--scenes", "packed/case01",
               "--modes", "batched,early-grasp", "--quiet"])
    out = capsys.readouterr().out
    assert rc == 0
    assert "lite         batched" in out and "agreement" in out and "heightmaps: 1 scenes" in out
    assert main(["bench", "--variants", "resnet", "--runs", "1", "--scenes", "packed/case01"]) == 2


def test_cases_file_round_trip_and_errors(tmp_path):
    from pg_learning.evaluation.bench import load_cases, save_cases

    cases = [_case(0), _case(1)]
    path = tmp_path / "cases.npz"
    save_cases(cases, path)
    back = load_cases(path)
    assert [c.name for c in back] == [c.name for c in cases]
    for a, b in zip(cases, back, strict=True):
        for field_ in ("color", "height", "valid", "bounds"):
            np.testing.assert_array_equal(getattr(a.heightmap, field_), getattr(b.heightmap, field_))
        assert a.heightmap.resolution == b.heightmap.resolution
        np.testing.assert_array_equal(a.target, b.target)
    bad = tmp_path / "bad.npz"
    bad.write_bytes(b"not an archive")
    with pytest.raises(ValueError, match="not a benchmark cases file"):
        load_cases(bad)
    with pytest.raises(ValueError, match="not a benchmark cases file"):
        load_cases(tmp_path / "missing.npz")


def test_bench_cli_on_cases_file(tmp_path, capsys):
    from pg_learning.evaluation.bench import save_cases

    path = tmp_path / "cases.npz"
    save_cases([_case(0)], path)
    assert main(["bench", "--cases", str(path), "--variants", "lite", "--runs", "1", "--modes",
                 "vpg-loop,batched", "--quiet"]) == 0
    out = capsys.readouterr().out
    assert "device cpu" in out and "heightmaps: 1 scenes" in out and "100.0% (1/1)" in out
    if not torch.cuda.is_available():
        assert main(["bench", "--cases", str(path), "--device", "cuda", "--quiet"]) != 0
        assert "no CUDA device" in capsys.readouterr().err


def test_the_policy_bench_times_the_shipped_decision_by_stage():
    from pg_learning.evaluation.policy_bench import bench_policy

    pb = bench_policy("lite", ["packed/case01"], runs=2, threads=1, verbose=False)
    assert len(pb.total_s) == 2 and pb.decisions_stable and pb.decisions["packed/case01"].startswith(("push", "grasp"))
    stages = set(pb.stages_s)
    assert {"perceive", "nets", "rule:grasp_check", "rerank", "decide"} <= stages
    parts = sum(float(np.mean(v)) for v in pb.stages_s.values())
    assert parts <= float(np.mean(pb.total_s))  # the stages account for no more than the whole call
    assert "Stage" in pb.report() and "decisions stable across calls: yes" in pb.report()


def test_the_cli_and_the_bench_on_saved_cases_need_no_simulator():
    """A GPU machine without PyBullet runs `pushgrasp bench --cases`: building the CLI's parser and importing the
    bench, the scene model and the scene families must not import pybullet or pybullet_data."""
    import subprocess
    import sys

    code = """
import importlib.abc, sys
class Block(importlib.abc.MetaPathFinder):
    def find_spec(self, name, path, target=None):
        if name.split(".")[0] in ("pybullet", "pybullet_data"):
            raise ModuleNotFoundError(f"No module named {name!r}")
sys.meta_path.insert(0, Block())
from pg_policy.cli.main import build_parser
build_parser()
import pg_learning.evaluation.bench, pg_sim.scenes.scene, pg_sim.world.scene_families, pg_sim.scenes.vpg_import
"""
    res = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert res.returncode == 0, res.stderr[-2000:]
