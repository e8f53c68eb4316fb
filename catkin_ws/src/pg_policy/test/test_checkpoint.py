"""pg_policy.models.checkpoint: checkpoints load without running pickled code."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import torch

from pg_policy.models.checkpoint import load_checkpoint


class _Payload:
    """Unpickling this would create `marker` (what a crafted checkpoint could do with any other call)."""

    def __init__(self, marker: Path) -> None:
        self.marker = marker

    def __reduce__(self):  # type: ignore[no-untyped-def]
        return (open, (str(self.marker), "w"))


def test_a_checkpoint_of_tensors_and_plain_values_loads(tmp_path: Path):
    net = torch.nn.Linear(3, 2)
    opt = torch.optim.Adam(net.parameters())
    net(torch.ones(1, 3)).sum().backward()
    opt.step()
    ck = {"nets": {"grasp": net.state_dict()}, "opts": {"grasp": opt.state_dict()}, "iteration": 7,
          "rng": np.random.default_rng(5).bit_generator.state, "config": {"backbone": "lite"}, "stage": "push"}
    torch.save(ck, tmp_path / "last.pt")
    back = load_checkpoint(tmp_path / "last.pt")
    assert back["iteration"] == 7 and torch.equal(back["nets"]["grasp"]["weight"], net.state_dict()["weight"])
    rng = np.random.default_rng()
    rng.bit_generator.state = back["rng"]
    assert rng.integers(1 << 30) == np.random.default_rng(5).integers(1 << 30)


def test_a_checkpoint_carrying_code_is_refused_not_run(tmp_path: Path):
    marker = tmp_path / "ran"
    torch.save({"nets": {}, "config": _Payload(marker)}, tmp_path / "evil.pt")
    with pytest.raises(ValueError, match="evil.pt: not a loadable training checkpoint"):
        load_checkpoint(tmp_path / "evil.pt")
    assert not marker.exists()
    (tmp_path / "garbage.pt").write_bytes(b"not a checkpoint")
    with pytest.raises(ValueError, match="garbage.pt"):
        load_checkpoint(tmp_path / "garbage.pt")
    with pytest.raises(FileNotFoundError):
        load_checkpoint(tmp_path / "missing.pt")
