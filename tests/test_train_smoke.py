"""Training smoke run: all four stages of a tiny config, resume, export, and the exported files load and act."""

import csv

import numpy as np
import pytest

from pg_policy.cli.main import main

STAGES = ("grasp-agnostic", "grasp-goal", "push", "alternate")


def _train(out, stage, iterations, scene):
    args = ["train", "--stage", stage, "--out", str(out), "--iterations", str(iterations), "--scene", scene,
            "--replay-capacity", "32", "--checkpoint-every", "2", "--epsilon-decay", "10", "--max-actions", "4"]
    assert main(args) == 0


@pytest.fixture(scope="module")
def run_dir(tmp_path_factory):
    out = tmp_path_factory.mktemp("run")
    for stage in STAGES:
        _train(out, stage, 3, "random-4" if stage.startswith("grasp") else "dense-4")
    return out


def test_every_stage_leaves_checkpoint_log_and_curve(run_dir):
    for stage in STAGES:
        d = run_dir / stage
        assert (d / "last.pt").exists() and (d / "curves.png").stat().st_size > 1000
        rows = list(csv.DictReader((d / "log.csv").open()))
        assert [int(r["iteration"]) for r in rows] == [0, 1, 2]
        assert all(r["primitive"] in ("grasp", "push") for r in rows)


def test_resume_continues_where_it_stopped(run_dir):
    _train(run_dir, "alternate", 5, "dense-4")
    rows = list(csv.DictReader((run_dir / "alternate" / "log.csv").open()))
    assert [int(r["iteration"]) for r in rows] == [0, 1, 2, 3, 4]


def test_later_stage_refuses_without_previous(tmp_path):
    with pytest.raises(FileNotFoundError, match="train stage 'push' first"):
        from pg_learning.training.config import TrainConfig
        from pg_learning.training.trainer import Trainer

        Trainer(TrainConfig(stage="alternate", out=tmp_path, iterations=1))


def test_export_loads_without_project_source_and_matches_checkpoint(run_dir, tmp_path):
    import torch

    from pg_policy.models.model_io import load_qnet

    assert main(["export", "--run", str(run_dir), "--out", str(tmp_path / "model")]) == 0
    ck = torch.load(run_dir / "alternate" / "last.pt", map_location="cpu", weights_only=False)
    for role in ("grasp", "push"):
        module, meta = load_qnet(tmp_path / "model" / f"{role}.pt")
        assert meta["role"] == role and meta["stage"] == "alternate" and meta["backbone"] == "lite"
        from pg_policy.models.nets.qnet import QNetConfig, build_qnet

        eager = build_qnet(QNetConfig("lite", "none", 16))
        eager.load_state_dict(ck["nets"][role])
        g = torch.Generator().manual_seed(0)
        color = torch.rand(1, 3, 224, 224, generator=g)
        depth = torch.rand(1, 1, 224, 224, generator=g) * 0.05
        mask = torch.zeros(1, 1, 224, 224)
        with torch.no_grad():
            np.testing.assert_allclose(module(color, depth, mask, [0, 5]).numpy(),
                                       eager(color, depth, mask, [0, 5]).numpy(), atol=1e-5)


def test_a_stage_can_start_from_exported_models(run_dir, tmp_path):
    import torch

    from pg_learning.training.config import TrainConfig
    from pg_learning.training.trainer import Trainer
    from pg_policy.models.model_io import ModelLoadError

    model = tmp_path / "model"
    assert main(["export", "--run", str(run_dir), "--out", str(model)]) == 0
    ck = torch.load(run_dir / "alternate" / "last.pt", map_location="cpu", weights_only=False)
    trainer = Trainer(TrainConfig(stage="grasp-goal", out=tmp_path / "fresh", iterations=1, init=model))
    try:
        for role in ("grasp", "push"):
            for k, v in ck["nets"][role].items():
                assert torch.equal(trainer.nets[role].state_dict()[k], v), (role, k)
    finally:
        trainer.env.close()
    with pytest.raises(ModelLoadError, match="this run trains"):
        Trainer(TrainConfig(stage="grasp-goal", out=tmp_path / "other", iterations=1, init=model, goal="mask"))
    dense = Trainer(TrainConfig(stage="grasp-goal", out=tmp_path / "dense", iterations=1, init=model,
                                backbone="lite-os8"))  # lite's weights at output stride 8
    try:
        assert int(dense.nets["grasp"].color_trunk.stride) == 8
        for k, v in ck["nets"]["grasp"].items():
            assert torch.equal(dense.nets["grasp"].state_dict()[k], v), k
    finally:
        dense.env.close()


def test_goal_conditioned_episode_ends_when_the_target_is_not_visible(run_dir, tmp_path):
    import numpy as np

    from pg_core.heightmap import Heightmap
    from pg_learning.environment.sim_env import EnvObservation
    from pg_learning.training.config import TrainConfig
    from pg_learning.training.trainer import Trainer

    trainer = Trainer(TrainConfig(stage="grasp-goal", out=tmp_path, iterations=1,
                                  init=run_dir / "grasp-agnostic" / "last.pt", scene="random-4"))
    try:
        obs = trainer._reset()
        assert not trainer._episode_over(obs)  # _reset only hands out scenes whose target is visible
        empty = Heightmap(np.zeros((224, 224, 3), np.uint8), np.zeros((224, 224), np.float32),
                          np.ones((224, 224), bool), 0.002, obs.heightmap.bounds)
        hidden = EnvObservation(empty, obs.target, np.zeros((224, 224), bool), obs.sim_time)
        assert trainer._episode_over(hidden)
    finally:
        trainer.env.close()


def test_guided_exploration_takes_the_heuristics_actions(run_dir, tmp_path):
    from pg_learning.training.config import TrainConfig
    from pg_learning.training.trainer import Trainer

    cfg = TrainConfig(stage="push", out=tmp_path, iterations=2, init=run_dir / "grasp-goal" / "last.pt",
                      scene="dense-4", epsilon_start=1.0, epsilon_end=1.0, guided_exploration=1.0,
                      early_grasp_threshold=10.0, replay_capacity=8, max_actions=4)
    Trainer(cfg).run()
    rows = list(csv.DictReader((tmp_path / "push" / "log.csv").open()))
    assert len(rows) == 2 and all(r["primitive"] == "push" and r["explored"] == "2" for r in rows)


def test_guided_exploration_takes_the_heuristics_free_grasps(run_dir, tmp_path):
    from pg_learning.training.config import TrainConfig
    from pg_learning.training.trainer import Trainer

    cfg = TrainConfig(stage="grasp-goal", out=tmp_path, iterations=2, init=run_dir / "grasp-agnostic" / "last.pt",
                      scene="random-4", epsilon_start=1.0, epsilon_end=1.0, guided_exploration=1.0,
                      replay_capacity=8, max_actions=4)
    Trainer(cfg).run()
    rows = list(csv.DictReader((tmp_path / "grasp-goal" / "log.csv").open()))
    assert len(rows) == 2 and all(r["primitive"] == "grasp" and r["explored"] == "2" for r in rows)


def test_alternate_push_budget_forces_grasps_and_is_exported(run_dir, tmp_path, capsys):
    import torch

    from pg_policy.models.model_io import load_qnet

    out = tmp_path / "budget"
    args = ["train", "--stage", "alternate", "--out", str(out), "--init", str(run_dir / "push" / "last.pt"),
            "--iterations", "6", "--scene", "dense-4", "--replay-capacity", "32", "--max-actions", "6",
            "--grasp-threshold", "1e9", "--push-budget", "1"]
    assert main(args) == 0
    rows = list(csv.DictReader((out / "alternate" / "log.csv").open()))
    pairs = list(zip(rows, rows[1:], strict=False))
    assert any(a["primitive"] == "push" and b["primitive"] == "grasp" for a, b in pairs)
    assert not any(a["primitive"] == b["primitive"] == "push" and a["episode"] == b["episode"] for a, b in pairs)
    assert main(["export", "--run", str(out), "--out", str(tmp_path / "model")]) == 0
    _, meta = load_qnet(tmp_path / "model" / "grasp.pt")
    assert meta["thresholds"] == {"grasp_q": 1e9, "push_budget": 1} and meta["rules"] == ["failed_grasps:0.01"]
    assert torch.load(out / "alternate" / "last.pt", weights_only=False)["config"]["push_budget"] == "1"
    assert main(["export", "--run", str(out), "--out", str(tmp_path / "filtered"), "--grasp-filter", "MIN3"]) == 0
    _, meta = load_qnet(tmp_path / "filtered" / "push.pt")
    assert meta["rules"] == ["grasp_filter:min3", "failed_grasps:0.01"]
    assert main(["export", "--run", str(out), "--out", str(tmp_path / "checked"), "--grasp-check", "jaw"]) == 0
    _, meta = load_qnet(tmp_path / "checked" / "grasp.pt")
    assert meta["rules"] == ["failed_grasps:0.01", "grasp_check:jaw"]
    assert main(["export", "--run", str(out), "--out", str(tmp_path / "guarded"), "--edge-guard", "on",
                 "--push-landing", "off"]) == 0
    _, meta = load_qnet(tmp_path / "guarded" / "push.pt")
    assert meta["rules"] == ["failed_grasps:0.01", "edge_guard"]
    assert main(["export", "--run", str(out), "--out", str(tmp_path / "bad"), "--grasp-filter", "max3"]) == 2
    assert "bad grasp filter" in capsys.readouterr().err and not (tmp_path / "bad").exists()


def test_a_scene_list_takes_its_families_in_turn(tmp_path):
    from pg_learning.training.config import TrainConfig
    from pg_learning.training.trainer import Trainer

    trainer = Trainer(TrainConfig(stage="grasp-agnostic", out=tmp_path, iterations=1, scene="dense-4, random-2"))
    try:
        counts = []
        for _ in range(3):
            trainer._reset()
            counts.append(len(trainer.env.world.objects))
        assert counts == [4, 2, 4]
    finally:
        trainer.env.close()


@pytest.mark.parametrize("scene", ["dense-8,", "packed-3", "random-0", "random-ten"])
def test_a_bad_scene_list_is_refused_before_anything_is_written(tmp_path, capsys, scene):
    out = tmp_path / "run"
    assert main(["train", "--stage", "grasp-agnostic", "--out", str(out), "--scene", scene]) == 2
    assert "is not a generated family" in capsys.readouterr().err and not out.exists()


@pytest.mark.parametrize("scene", ["novel-10", "dense-8,novel-packed-8", "mixed-15"])
def test_held_out_objects_are_never_trained_on(tmp_path, capsys, scene):
    out = tmp_path / "run"
    assert main(["train", "--stage", "grasp-agnostic", "--out", str(out), "--scene", scene]) == 2
    assert "held-out objects" in capsys.readouterr().err and not out.exists()


@pytest.mark.parametrize("device", ["gpu", "mps", "cuda:7"])
def test_a_device_this_machine_lacks_is_refused_before_anything_is_written(tmp_path, capsys, device):
    import torch

    if device == "cuda:7" and torch.cuda.device_count() > 7:
        pytest.skip("opt-in: this machine has eight CUDA devices (the test needs a missing cuda:7)")
    out = tmp_path / "run"
    assert main(["train", "--stage", "grasp-agnostic", "--out", str(out), "--device", device]) == 2
    assert f"--device {device!r}" in capsys.readouterr().err and not out.exists()


def test_a_cuda_run_checkpoints_loadable_on_the_cpu(tmp_path):
    import torch

    if not torch.cuda.is_available():
        pytest.skip("opt-in: no CUDA device on this machine")
    _train(tmp_path, "grasp-agnostic", 2, "random-3")
    assert main(["train", "--stage", "grasp-agnostic", "--out", str(tmp_path), "--iterations", "3", "--scene",
                 "random-3", "--device", "cuda", "--replay-capacity", "32", "--max-actions", "4"]) == 0
    ck = torch.load(tmp_path / "grasp-agnostic" / "last.pt", map_location="cpu", weights_only=False)
    assert ck["iteration"] == 3 and all(v.device.type == "cpu" for v in ck["nets"]["grasp"].values())
