"""Experience collection: the Collector's episode numbering, the serial learner's determinism and resume, and a
short `pushgrasp train --collectors 2` run on a local two-node Ray cluster that resumes from its checkpoint."""

from __future__ import annotations

import csv
from pathlib import Path

import pytest
import torch

from pg_learning.training.collector import Collector
from pg_learning.training.config import TrainConfig
from pg_learning.training.trainer import LOG_FIELDS, Trainer
from pg_policy.cli.main import main

TINY = ["--scene", "random-4", "--replay-capacity", "32", "--max-actions", "4", "--threads", "1"]


def _rows(path: Path) -> list[dict[str, str]]:
    with path.open(newline="") as f:
        return list(csv.DictReader(f))


def _episodes(collector: Collector, n: int) -> list[int]:
    out = []
    for _ in range(n):
        collector._reset()
        out.append(collector.episode)
    return out


def test_collector_c_of_n_numbers_its_episodes_apart_from_the_others(tmp_path):
    cfg = TrainConfig(stage="grasp-agnostic", out=tmp_path, scene="random-2")
    serial = Collector(cfg)  # index 0 of 1: the serial loop's numbering 1, 2, 3, ...
    second = Collector(cfg, index=1, count=3, first_episode=10)
    try:
        assert _episodes(serial, 3) == [1, 2, 3]
        assert _episodes(second, 3) == [12, 15, 18]
        transition, row = second.step(0)  # no observation to act on yet: starts the next episode
        assert row["episode"] == 21 and transition.primitive == "grasp"
        assert second.step(1)[1]["episode"] == 21
        assert set(row) == set(LOG_FIELDS) - {"loss", "wall_s", "collector"}
    finally:
        serial.close()
        second.close()
    with pytest.raises(ValueError, match="collector index 3"):
        Collector(cfg, index=3, count=3)


def test_goal_stage_collectors_skip_scenes_within_their_own_numbers(tmp_path):
    cfg = TrainConfig(stage="grasp-goal", out=tmp_path, scene="random-4")
    collectors = [Collector(cfg, index=c, count=2, first_episode=4) for c in range(2)]
    try:
        seen = [_episodes(col, 3) for col in collectors]
    finally:
        for col in collectors:
            col.close()
    assert all((e - 4 - 1 - c) % 2 == 0 for c, eps in enumerate(seen) for e in eps)  # scenes disjoint by parity
    assert all(a < b for eps in seen for a, b in zip(eps, eps[1:], strict=False))


def test_a_scene_that_cannot_be_built_is_skipped_and_reported(tmp_path, capsys):
    cfg = TrainConfig(stage="grasp-agnostic", out=tmp_path, scene="random-2")
    col = Collector(cfg)
    real_reset, calls = col.env.reset, []

    def reset(scene, seed=None):  # the real simulator, except that episode 2's scene has a broken object file
        calls.append(seed)
        if len(calls) == 2:
            raise ValueError("blob.obj: 35 of 35 OBJ vertices are not finite")
        return real_reset(scene, seed=seed)

    col.env.reset = reset
    try:
        assert _episodes(col, 2) == [1, 3]  # episode 2 skipped, its number used up
        assert "episode 2: scene random-2" in capsys.readouterr().err
        col.env.reset = lambda scene, seed=None: (_ for _ in ()).throw(ValueError("bad scene"))
        with pytest.raises(RuntimeError, match="no training scene could be built in 10 draws; last: .*bad scene"):
            col._reset()
    finally:
        col.close()


def test_serial_learner_is_deterministic_and_resumes_with_the_next_episode(tmp_path):
    """Same seed, same log (but wall_s); the serial loop draws its random numbers in the order of the single-process
    trainer it replaced. (A resumed run is not bit-identical to an uninterrupted one: a PyBullet world's reset
    depends on the episodes played before it.)"""
    args = ["train", "--stage", "grasp-agnostic", "--checkpoint-every", "4", "--iterations", "4", *TINY]
    for run in ("a", "b"):
        assert main([*args, "--out", str(tmp_path / run)]) == 0
    a, b = (_rows(tmp_path / run / "grasp-agnostic" / "log.csv") for run in ("a", "b"))
    for rows in (a, b):
        for r in rows:
            r.pop("wall_s")
    assert a == b and [r["collector"] for r in a] == ["0"] * 4 and [r["episode"] for r in a] == ["1"] * 4
    ck_a, ck_b = (torch.load(tmp_path / run / "grasp-agnostic" / "last.pt", weights_only=False) for run in "ab")
    assert ck_a["episode"] == ck_b["episode"] == 1 and ck_a["rng"] == ck_b["rng"]  # episode 1 is over, 2 not begun
    assert all(torch.equal(v, ck_b["nets"]["grasp"][k]) for k, v in ck_a["nets"]["grasp"].items())
    assert main([*args, "--out", str(tmp_path / "b"), "--iterations", "5"]) == 0  # the last --iterations counts
    rows = _rows(tmp_path / "b" / "grasp-agnostic" / "log.csv")
    assert [(r["iteration"], r["episode"]) for r in rows[3:]] == [("3", "1"), ("4", "2")]


def test_collector_flags_are_checked_before_anything_is_written(tmp_path, capsys):
    out = tmp_path / "run"
    for bad, message in ((["--collectors", "-1"], "--collectors -1"), (["--weights-every", "0"], "--weights-every 0"),
                         (["--ray-address", "auto"], "needs --collectors")):
        assert main(["train", "--out", str(out), *bad]) == 2
        assert message in capsys.readouterr().err and not out.exists()


def test_serial_trainer_does_not_import_ray(tmp_path):
    import subprocess
    import sys

    code = ("import sys; from pg_learning.training.trainer import Trainer; "
            "from pg_learning.training.config import TrainConfig; "
            f"t = Trainer(TrainConfig(stage='grasp-agnostic', out={str(tmp_path)!r})); t.env.close(); "
            "sys.exit(1 if 'ray' in sys.modules else 0)")
    assert subprocess.run([sys.executable, "-c", code], capture_output=True, timeout=120).returncode == 0


def test_training_with_two_ray_collectors_resumes_from_its_checkpoint(ray_two_nodes, tmp_path):
    """Two collectors (one per node) stream transitions to the learner; a second run resumes from the checkpoint:
    iterations continue, both collectors contribute, and episode numbers continue after the checkpointed one."""
    out = tmp_path / "run"
    args = ["train", "--stage", "grasp-agnostic", "--out", str(out), "--checkpoint-every", "2", "--weights-every", "1",
            "--collectors", "2", "--ray-address", ray_two_nodes, *TINY]
    assert main([*args, "--iterations", "3"]) == 0
    first = torch.load(out / "grasp-agnostic" / "last.pt", weights_only=False)
    assert first["iteration"] == 3 and first["episode"] >= 1
    assert main([*args, "--iterations", "7"]) == 0
    rows = _rows(out / "grasp-agnostic" / "log.csv")
    assert [int(r["iteration"]) for r in rows] == list(range(7))
    assert {r["collector"] for r in rows} == {"0", "1"}
    later = [r for r in rows if int(r["iteration"]) >= 3]
    # the resumed collectors number their episodes after the checkpoint's: collector c of 2 takes E + c + 1, + 2, ...
    assert all(int(r["episode"]) > first["episode"] for r in later)
    assert all((int(r["episode"]) - first["episode"] - 1 - int(r["collector"])) % 2 == 0 for r in later)
    last = torch.load(out / "grasp-agnostic" / "last.pt", weights_only=False)
    assert last["iteration"] == 7 and last["episode"] > first["episode"]
    assert last["episode"] == max(int(r["episode"]) for r in rows)


def test_a_serial_trainer_has_its_collector_and_a_ray_one_has_none_and_old_logs_keep_their_columns(tmp_path):
    serial = Trainer(TrainConfig(stage="grasp-agnostic", out=tmp_path / "s"))
    try:
        assert serial.collector is not None and serial.collector.nets is serial.nets
        assert serial.collector.rng is serial.rng
        assert serial._log_fields() == LOG_FIELDS
        serial.log_.write_text(",".join(LOG_FIELDS[:-1]) + "\n")  # a log.csv of the trainer before collectors
        assert serial._log_fields() == LOG_FIELDS[:-1]  # a resumed run appends rows with its columns
    finally:
        serial.env.close()
    assert Trainer(TrainConfig(stage="grasp-agnostic", out=tmp_path / "r", collectors=2)).collector is None


def test_ray_collectors_restart_a_dead_collector_once_and_bound_their_waits(ray_two_nodes, tmp_path, capsys):
    import ray

    from pg_learning.training.ray_collectors import RayCollectors

    cfg = TrainConfig(stage="grasp-agnostic", out=tmp_path, scene="random-4", max_actions=2, collectors=2)
    weights = Trainer(cfg).weights()
    with RayCollectors(cfg, 2, ray_two_nodes, weights=weights, timeout_s=0.5) as early:
        with pytest.raises(TimeoutError, match="no transition from the 2 collector"):
            early.next(0)  # the actors are still starting
    with RayCollectors(cfg, 2, ray_two_nodes, weights=weights) as rc:
        seen: dict[int, list[int]] = {0: [], 1: []}

        def until_slot(slot: int) -> None:
            for _ in range(10):
                _, row, c = rc.next(0)
                seen[c].append(int(row["episode"]))
                if c == slot:
                    return
            raise AssertionError(f"no transition from collector {slot}")

        until_slot(0)
        ray.kill(rc.actors[0], no_restart=True)
        until_slot(0)  # played by the restarted collector
        assert "collector 0 died" in capsys.readouterr().out
        assert all(e % 2 == 1 for e in seen[0]) and seen[0] == sorted(seen[0]) and len(set(seen[0])) == len(seen[0])
        ray.kill(rc.actors[0], no_restart=True)
        with pytest.raises(RuntimeError, match="collector 0 died a second time"):
            for _ in range(10):
                rc.next(0)


def test_an_empty_log_left_by_a_run_stopped_before_its_first_row_gets_its_header(tmp_path):
    (tmp_path / "grasp-agnostic").mkdir()
    (tmp_path / "grasp-agnostic" / "log.csv").write_text("")
    assert main(["train", "--stage", "grasp-agnostic", "--out", str(tmp_path), "--iterations", "2", "--scene",
                 "random-3", "--replay-capacity", "8", "--max-actions", "2"]) == 0
    rows = _rows(tmp_path / "grasp-agnostic" / "log.csv")
    assert [int(r["iteration"]) for r in rows] == [0, 1] and (tmp_path / "grasp-agnostic" / "curves.png").exists()
