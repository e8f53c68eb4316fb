"""Offline (batch) Q-learning from recorded experience: the paper's loss without the simulator in the loop.

For machines that can run the nets but not PyBullet (a lent GPU machine). `pack` gathers the filled part of
training replay buffers (`pg_learning.training.experience_replay` layout: one directory per primitive) into one
compressed .npz;
`OfflineTrainer` then learns from it: Huber loss on the executed pixel (a grasp also at rotation r + R/2), grasp
label = its reward, push label = reward + gamma * max(masked max Q_g, masked max Q_p) of the next observation
(0 when the episode ended), both nets on `device`, minibatches drawn uniformly. The experience comes from
another policy (off-policy, no exploration of its own): a deviation from the paper's self-supervised loop,
documented where its results are reported. The checkpoint has `pg_learning.training.trainer`'s layout under
OUT/offline/last.pt, so `pushgrasp export --run OUT` writes the deployable TorchScript files.
"""

from __future__ import annotations

import json
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import torch

from pg_learning.training import qtensor
from pg_learning.training.experience_replay import PRIMITIVES, ReplayBuffer


def pack(replay_dirs: list[Path], out: Path) -> dict[str, int]:
    """Filled transitions of every replay directory -> one .npz of {primitive}_{field} arrays
    (`ReplayBuffer.filled`: colour (N, H, W, 3) uint8, height (N, H, W) float16 m, mask (N, H, W) bool, action
    (N, 4) int32 (primitive, rotation, row, col), reward (N,) float32, and for pushes next_* and done). Returns
    transitions per primitive. Raises FileNotFoundError for a directory without meta.json, ValueError for
    mismatched heightmap shapes."""
    parts: dict[str, list[dict[str, np.ndarray]]] = {p: [] for p in PRIMITIVES}
    shapes = set()
    for d in map(Path, replay_dirs):
        meta_path = d / "meta.json"
        if not meta_path.is_file():
            raise FileNotFoundError(f"{d}: not a replay buffer directory (no meta.json)")
        meta = json.loads(meta_path.read_text())
        shapes.add(tuple(meta["shape"]))
        buf = ReplayBuffer(d, int(meta["capacity"]), tuple(meta["shape"]))
        for prim in PRIMITIVES:
            parts[prim].append(buf.filled(prim))
    if len(shapes) > 1:
        raise ValueError(f"replay buffers of different heightmap shapes: {sorted(shapes)}")
    arrays = {f"{p}_{f}": np.concatenate([part[f] for part in parts[p]]) for p in PRIMITIVES if parts[p]
              for f in parts[p][0]}
    Path(out).parent.mkdir(parents=True, exist_ok=True)
    np.savez_compressed(out, **arrays)
    return {p: int(len(arrays[f"{p}_reward"])) if f"{p}_reward" in arrays else 0 for p in PRIMITIVES}


@dataclass
class OfflineConfig:
    data: Path  # .npz from `pack`
    out: Path  # run directory (OUT/offline/last.pt, log.csv)
    backbone: str = "densenet121"
    goal: str = "none"
    rotations: int = 16
    pretrained: Path | None = None
    steps: int = 2000  # optimiser steps per net
    batch: int = 8  # transitions per step and net
    lr: float = 1e-4
    weight_decay: float = 2e-5
    gamma: float = 0.5
    grasp_threshold: float = 0.7  # stored for export (the decision rule's threshold)
    push_budget: int = 3  # stored for export
    device: str = "cpu"
    seed: int = 0
    minutes: float = 0.0  # wall-clock budget (0 = none)
    log_every: int = 50


class OfflineTrainer:
    """Both nets of one variant, trained from a packed experience file on `cfg.device`."""

    def __init__(self, cfg: OfflineConfig) -> None:
        self.cfg = cfg
        self.device = torch.device(cfg.device)
        torch.manual_seed(cfg.seed)
        self.rng = np.random.default_rng(cfg.seed)
        if not Path(cfg.data).is_file():
            raise FileNotFoundError(f"{cfg.data}: no such experience file (write it with `pushgrasp offline pack`)")
        try:
            with np.load(cfg.data, allow_pickle=False) as z:
                self.data = {k: z[k] for k in z.files}
        except (OSError, ValueError) as e:
            raise ValueError(f"{cfg.data}: not a packed experience file ({e})") from e
        if "grasp_reward" not in self.data:
            raise ValueError(f"{cfg.data}: no grasp transitions (write it with `pushgrasp offline pack`)")
        self.nets = {r: qtensor.build(cfg, r).to(self.device) for r in PRIMITIVES}
        self.opts = {r: torch.optim.Adam(n.parameters(), lr=cfg.lr, weight_decay=cfg.weight_decay)
                     for r, n in self.nets.items()}
        self.dir = Path(cfg.out) / "offline"
        self.dir.mkdir(parents=True, exist_ok=True)

    def _inputs(self, role: str, idx: np.ndarray, prefix: str = "") -> tuple[torch.Tensor, ...]:
        d = self.data
        return qtensor.tensors(d[f"{role}_{prefix}color"][idx], d[f"{role}_{prefix}height"][idx],
                               d[f"{role}_{prefix}mask"][idx], self.device)

    @torch.no_grad()
    def _push_labels(self, idx: np.ndarray) -> torch.Tensor:
        """reward + gamma * max over both nets of the masked max Q of the next observation (0 if done)."""
        d = self.data
        reward = torch.from_numpy(d["push_reward"][idx]).to(self.device)
        done = torch.from_numpy(d["push_done"][idx]).to(self.device)
        c, h, m = self._inputs("push", idx, "next_")
        future = torch.full_like(reward, -1.0)
        for net in self.nets.values():
            net.eval()
            q = net(c, h, m, None)  # (B, R, H, W)
            masked = torch.where(m.bool().expand_as(q), q, torch.full_like(q, -1e9)).flatten(1).amax(1)
            future = torch.maximum(future, masked)
        future = torch.where(m.flatten(1).any(1), future, torch.full_like(future, -1.0))  # empty mask: as qtensor
        return reward + self.cfg.gamma * torch.where(done, torch.zeros_like(future), future)

    def step(self, role: str) -> float:
        """One Huber step of `role`'s net on a uniform minibatch; returns the loss."""
        n = len(self.data[f"{role}_reward"])
        if n == 0:
            return float("nan")
        idx = self.rng.integers(0, n, size=min(self.cfg.batch, n))
        labels = (torch.from_numpy(self.data["grasp_reward"][idx]).to(self.device) if role == "grasp"
                  else self._push_labels(idx))
        action = torch.from_numpy(self.data[f"{role}_action"][idx].astype(np.int64)).to(self.device)
        c, h, m = self._inputs(role, idx)
        rot, row, col = action[:, 1], action[:, 2], action[:, 3]
        if role == "grasp":  # the parallel jaw is symmetric: the same label at r + R/2
            half = self.cfg.rotations // 2
            c, h, m = c.repeat(2, 1, 1, 1), h.repeat(2, 1, 1, 1), m.repeat(2, 1, 1, 1)
            rot = torch.cat([rot, (rot + half) % self.cfg.rotations])
            row, col, labels = row.repeat(2), col.repeat(2), labels.repeat(2)
        net, opt = self.nets[role], self.opts[role]
        net.train()
        q = net.forward_indexed(c, h, m, rot)  # (N, H, W)
        pred = q[torch.arange(q.shape[0], device=self.device), row, col]
        loss = torch.nn.functional.smooth_l1_loss(pred, labels.to(pred.dtype))
        opt.zero_grad()
        loss.backward()
        opt.step()
        return float(loss.detach())

    def run(self) -> Path:
        """`steps` steps per net (or until `minutes`), a log.csv line every `log_every`; returns the checkpoint."""
        from tqdm import tqdm

        t0 = time.monotonic()
        log = (self.dir / "log.csv").open("w")
        log.write("step,grasp_loss,push_loss,wall_s\n")
        bar = tqdm(range(self.cfg.steps), desc=f"offline {self.cfg.backbone}", unit="step")
        for i in bar:
            losses = {r: self.step(r) for r in PRIMITIVES}
            bar.set_postfix(grasp=f"{losses['grasp']:.3f}", push=f"{losses['push']:.3f}")
            if (i + 1) % self.cfg.log_every == 0:
                log.write(f"{i + 1},{losses['grasp']:.5f},{losses['push']:.5f},{time.monotonic() - t0:.1f}\n")
                log.flush()
            if self.cfg.minutes and time.monotonic() - t0 > 60.0 * self.cfg.minutes:
                break
        log.close()
        return self.save(i + 1)

    def save(self, steps: int) -> Path:
        ck = {"nets": {r: {k: v.cpu() for k, v in n.state_dict().items()} for r, n in self.nets.items()},
              "iteration": steps, "episode": 0, "stage": "offline",
              "config": {k: str(v) for k, v in vars(self.cfg).items()}}
        tmp = self.dir / "last.pt.tmp"
        torch.save(ck, tmp)
        tmp.replace(self.dir / "last.pt")
        return self.dir / "last.pt"
