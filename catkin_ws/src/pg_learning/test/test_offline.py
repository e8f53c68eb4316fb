"""Offline Q-learning from packed replay buffers: packing, a few real optimiser steps, export of the result."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from pg_learning.training.experience_replay import ReplayBuffer, Transition
from pg_learning.training.offline import OfflineConfig, OfflineTrainer, pack
from pg_policy.cli.main import main

torch.set_num_threads(2)
SHAPE = (32, 32)


def _transition(rng: np.random.Generator, primitive: str) -> Transition:
    color = rng.integers(0, 255, (*SHAPE, 3), dtype=np.uint8)
    height = rng.uniform(0, 0.05, SHAPE).astype(np.float32)
    mask = np.zeros(SHAPE, bool)
    mask[10:20, 12:22] = True
    push = primitive == "push"
    return Transition(color, height, mask, primitive, int(rng.integers(16)), int(rng.integers(32)),
                      int(rng.integers(32)), float(rng.integers(2)) if not push else 0.5,
                      next_color=color if push else None, next_height=height if push else None,
                      next_mask=mask if push else None, done=not push)


@pytest.fixture(scope="module")
def replays(tmp_path_factory):
    root = tmp_path_factory.mktemp("run")
    rng = np.random.default_rng(0)
    dirs = []
    for prim, n in (("grasp", 5), ("push", 3)):
        buf = ReplayBuffer(root / f"replay_{prim}", 10, SHAPE)
        for _ in range(n):
            buf.add(_transition(rng, prim))
        buf.flush()
        dirs.append(root / f"replay_{prim}")
    return dirs


def test_pack_keeps_the_filled_transitions(replays, tmp_path):
    counts = pack(replays, tmp_path / "exp.npz")
    assert counts == {"grasp": 5, "push": 3}
    with np.load(tmp_path / "exp.npz") as z:
        assert z["grasp_color"].shape == (5, *SHAPE, 3) and z["push_next_height"].shape == (3, *SHAPE)
        assert set(np.unique(z["push_reward"])) == {0.5}
    with pytest.raises(FileNotFoundError, match="not a replay buffer"):
        pack([tmp_path], tmp_path / "bad.npz")


def test_offline_steps_learn_and_export(replays, tmp_path):
    pack(replays, tmp_path / "exp.npz")
    cfg = OfflineConfig(data=tmp_path / "exp.npz", out=tmp_path / "run", backbone="lite", goal="none", steps=3,
                        batch=2, lr=1e-2, log_every=1)
    trainer = OfflineTrainer(cfg)
    before = {k: v.clone() for k, v in trainer.nets["push"].state_dict().items()}
    ck = trainer.run()
    after = trainer.nets["push"].state_dict()
    assert any(not torch.equal(before[k], after[k]) for k in before if before[k].is_floating_point())
    assert (tmp_path / "run" / "offline" / "log.csv").read_text().count("\n") == 4
    saved = torch.load(ck, weights_only=False)
    assert saved["stage"] == "offline" and saved["iteration"] == 3
    assert main(["export", "--run", str(tmp_path / "run"), "--out", str(tmp_path / "model")]) == 0
    assert (tmp_path / "model" / "grasp.pt").is_file() and (tmp_path / "model" / "push.pt").is_file()


def test_push_label_is_reward_plus_discounted_best_next_q(replays, tmp_path):
    pack(replays, tmp_path / "exp.npz")
    trainer = OfflineTrainer(OfflineConfig(data=tmp_path / "exp.npz", out=tmp_path / "run", backbone="lite"))
    idx = np.array([0, 1])
    labels = trainer._push_labels(idx).numpy()
    z = trainer.data
    best = []
    for i in idx:
        c = torch.from_numpy(z["push_next_color"][i]).permute(2, 0, 1)[None].float() / 255.0
        h = torch.from_numpy(z["push_next_height"][i].astype(np.float32))[None, None]
        m = torch.from_numpy(z["push_next_mask"][i])
        with torch.no_grad():
            q = [net.eval()(c, h, None, None)[0][:, m].max() for net in trainer.nets.values()]
        best.append(float(max(q)))
    np.testing.assert_allclose(labels, 0.5 + 0.5 * np.array(best), atol=1e-5)


def test_offline_cli_errors(tmp_path, capsys):
    np.savez(tmp_path / "empty.npz", push_reward=np.zeros(1, np.float32))
    assert main(["offline", "train", "--data", str(tmp_path / "empty.npz"), "--out", str(tmp_path / "r"),
                 "--backbone", "lite"]) == 2
    assert "no grasp transitions" in capsys.readouterr().err
    (tmp_path / "junk.npz").write_bytes(b"junk")
    assert main(["offline", "train", "--data", str(tmp_path / "junk.npz"), "--out", str(tmp_path / "r"),
                 "--backbone", "lite"]) == 2
    assert "not a packed experience file" in capsys.readouterr().err
    assert main(["offline", "train", "--data", str(tmp_path / "none.npz"), "--out", str(tmp_path / "r"),
                 "--backbone", "lite"]) == 2
    assert "no such experience file" in capsys.readouterr().err
    if not torch.cuda.is_available():
        assert main(["offline", "train", "--data", str(tmp_path / "empty.npz"), "--out", str(tmp_path / "r"),
                     "--device", "cuda"]) == 2
        assert "no CUDA device" in capsys.readouterr().err
