"""Self-supervised training loop of the paper: act in the simulator, label the executed pixel, learn, repeat.

One iteration = one transition from a collector (`pg_learning.training.collector`: observe -> masked Q maps ->
epsilon-greedy decision -> execute -> reward with hindsight relabelling) -> store in prioritised replay -> Huber loss
on the executed pixel (grasps also at rotation r + R/2) for the new transition batched with `replay_samples` replayed
ones -> log. One learner update per environment step, whoever played it.

`Trainer` is the learner: nets, optimisers, replay, checkpoints, log.csv, on `--device`. Its transitions come from
- `--collectors 0` (default): one Collector in this process that shares the learner's nets and random generator and
  steps when asked, so the run is the paper's serial loop (act with the latest weights, learn, next action) and
  draws its random numbers in the same order as before the split;
- `--collectors N`: N Ray actors (`pg_learning.training.ray_collectors`) that play in parallel with CPU copies of the
  nets, refreshed every `weights_every` updates; the learner takes their transitions in arrival order, so a
  transition is acted with weights about weights_every + N updates old at most when collectors are equally fast
  (off-policy lag, `pg_learning.training.ray_collectors`; Q-learning from replay tolerates it).
Checkpoints (nets, optimisers, counters, RNG state; the replay lives on disk) every `checkpoint_every` iterations and
on Ctrl-C: rerunning the same command resumes, and collectors restart from the checkpointed weights with episode
numbers after the highest one started before. The `collector` column of log.csv names the collector of each row.
"""

from __future__ import annotations

import csv
import json
import signal
import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any, Protocol

import numpy as np
import torch

from pg_core.geometry import load
from pg_core.heightmap import Heightmap
from pg_learning.environment.sim_env import SimEnv
from pg_learning.training import qtensor
from pg_learning.training.collector import ROLES, Collector, LocalCollector
from pg_learning.training.config import TrainConfig
from pg_learning.training.curves import plot_curves
from pg_learning.training.experience_replay import ReplayBuffer, Transition
from pg_learning.training.stages import STAGES
from pg_policy.models.checkpoint import load_checkpoint
from pg_policy.models.device import check_device
from pg_policy.models.model_io import ModelLoadError, load_qnet
from pg_policy.models.nets.registry import get_backbone

# explored: 0 = greedy, 1 = uniformly random, 2 = the heuristic's push or free grasp (guided exploration);
# collector: index of the collector that played the row (0 in the serial loop)
LOG_FIELDS = ["iteration", "episode", "primitive", "rotation", "row", "col", "q", "explored", "reward", "grasped",
              "success", "epsilon", "loss", "sim_s", "wall_s", "collector"]

StateDicts = dict[str, dict[str, torch.Tensor]]


class Source(Protocol):
    """Where transitions come from: LocalCollector (serial) or RayCollectors."""

    def __enter__(self) -> Source: ...

    def __exit__(self, *exc: object) -> None: ...

    def next(self, iteration: int) -> tuple[Transition, dict[str, Any], int]: ...

    def broadcast(self, state_dicts: StateDicts, iteration: int) -> None: ...


class Trainer:
    """The learner of one stage of one run directory: the two nets, their optimisers and replay buffers; with
    `collectors == 0` also the in-process Collector (`collector`, its simulator `env`)."""

    def __init__(self, cfg: TrainConfig) -> None:
        torch.set_num_threads(cfg.threads)
        torch.manual_seed(cfg.seed)
        self.cfg = cfg
        self.device = check_device(cfg.device)
        self.geo = load()
        self.stage = STAGES[cfg.stage]
        self.dir = Path(cfg.out) / cfg.stage
        self.dir.mkdir(parents=True, exist_ok=True)
        self.nets = {role: qtensor.build(cfg, role).to(self.device) for role in ROLES}
        self.opts = {role: torch.optim.Adam(net.parameters(), lr=cfg.lr, weight_decay=cfg.weight_decay)
                     for role, net in self.nets.items()}
        shape = (self.geo.heightmap.rows, self.geo.heightmap.cols)
        self.replay = {role: ReplayBuffer(self.dir / f"replay_{role}", cfg.replay_capacity, shape)
                       for role in self.stage.trains}
        self.iteration = 0
        self.episode = 0  # the highest episode number started by any collector (checkpointed)
        self.rng = np.random.default_rng(cfg.seed)
        self._restore()
        self.collector: Collector | None = None
        self.env: SimEnv | None = None
        if cfg.collectors == 0:  # the serial loop: acts with these nets and draws from this generator
            self.collector = Collector(cfg, 0, 1, self.episode, nets=self.nets, rng=self.rng, geo=self.geo)
            self.env = self.collector.env
        self.log_ = self.dir / "log.csv"

    # -- the serial collector's episodes (kept for callers of the single-process trainer) ----------------------
    def _reset(self, draws: int = 10) -> Any:
        assert self.collector is not None, "no in-process collector (collectors > 0)"
        return self.collector._reset(draws)

    def _episode_over(self, obs: Any = None) -> bool:
        assert self.collector is not None, "no in-process collector (collectors > 0)"
        return self.collector._episode_over(obs)

    # -- checkpoints -------------------------------------------------------------------------------------------
    def _restore(self) -> None:
        last = self.dir / "last.pt"
        if last.exists():
            ck = load_checkpoint(last)
            for role, net in self.nets.items():
                net.load_state_dict(ck["nets"][role])
            for role, opt in self.opts.items():
                if role in ck["opts"]:
                    opt.load_state_dict(ck["opts"][role])
            self.iteration, self.episode = ck["iteration"], ck["episode"]
            self.rng.bit_generator.state = ck["rng"]
            print(f"[train] resuming {self.stage.name} at iteration {self.iteration} from {last}")
            return
        init = self.cfg.init or (Path(self.cfg.out) / self.stage.previous / "last.pt" if self.stage.previous else None)
        if init is not None:
            if not Path(init).exists():
                raise FileNotFoundError(f"stage {self.stage.name} starts from {init}, which does not exist: train "
                                        f"stage '{self.stage.previous}' first or pass --init")
            if Path(init).is_dir():
                self._init_from_models(Path(init))
            else:
                ck = load_checkpoint(init)
                for role, net in self.nets.items():
                    net.load_state_dict(ck["nets"][role])
            print(f"[train] {self.stage.name}: starting from {init}")

    def _init_from_models(self, folder: Path) -> None:
        """Weights from exported TorchScript files (`pushgrasp export` layout); a net without a file keeps its
        fresh initialisation. Raises ModelLoadError for a file made for another backbone or goal input."""

        for role, net in self.nets.items():
            path = folder / f"{role}.pt"
            if not path.is_file():
                print(f"[train] {role} net: no {path}, starting from scratch")
                continue
            scripted, meta = load_qnet(path)
            takes = (self.cfg.backbone, *get_backbone(self.cfg.backbone).weights_of)
            if meta.get("backbone") not in takes or meta.get("goal") != self.cfg.goal:
                raise ModelLoadError(f"{path} is a {meta.get('backbone')!r} / goal {meta.get('goal')!r} model; this "
                                     f"run trains {self.cfg.backbone!r} / goal {self.cfg.goal!r}")
            own = net.state_dict()
            net.load_state_dict({k: v for k, v in scripted.state_dict().items() if k in own})

    def save(self) -> Path:
        for buf in self.replay.values():
            buf.flush()
        ck = {"nets": {r: {k: v.cpu() for k, v in n.state_dict().items()} for r, n in self.nets.items()},
              "opts": {r: o.state_dict() for r, o in self.opts.items()},
              "iteration": self.iteration, "episode": self.episode, "rng": self.rng.bit_generator.state,
              "config": {k: str(v) for k, v in vars(self.cfg).items()}, "stage": self.stage.name}
        tmp = self.dir / "last.pt.tmp"
        torch.save(ck, tmp)
        tmp.replace(self.dir / "last.pt")
        return self.dir / "last.pt"

    # -- learning ----------------------------------------------------------------------------------------------
    def _label(self, t: Transition) -> float:
        if t.primitive == "grasp" or t.done:
            return t.reward
        hm = Heightmap(t.next_color, t.next_height, t.next_height > 0, self.geo.heightmap.resolution,
                       self.geo.workspace.bounds)
        q = qtensor.q_maps(self.nets, hm, t.next_mask, ("grasp", "push"))
        future = max(qtensor.masked_max(q["grasp"], t.next_mask), qtensor.masked_max(q["push"], t.next_mask))
        return t.reward + self.cfg.gamma * future

    def learn(self, batch: list[Transition]) -> tuple[float, list[float]]:
        """One Huber step on the executed pixels of a batch of transitions of one primitive (a grasp also at
        rotation r + R/2: the parallel jaw is symmetric). Returns (mean loss, |TD error| per transition)."""
        role = batch[0].primitive
        net, opt = self.nets[role], self.opts[role]
        labels = [self._label(t) for t in batch]
        half = self.cfg.rotations // 2
        items = [(k, t, r) for k, t in enumerate(batch)
                 for r in ([t.rotation, (t.rotation + half) % self.cfg.rotations] if role == "grasp" else [t.rotation])]
        cols = [qtensor.tensors(t.color, t.height, t.mask, self.device) for _, t, _ in items]
        color, depth, mask = (torch.cat([c[i] for c in cols]) for i in range(3))
        net.train()
        rots = torch.tensor([r for _, _, r in items], dtype=torch.int64, device=self.device)
        q = net.forward_indexed(color, depth, mask, rots)
        pred = torch.stack([q[i, t.row, t.col] for i, (_, t, _) in enumerate(items)])
        target = torch.tensor([labels[k] for k, _, _ in items], dtype=pred.dtype, device=self.device)
        loss = torch.nn.functional.smooth_l1_loss(pred, target, reduction="mean")
        opt.zero_grad()
        loss.backward()
        opt.step()
        first = {}
        values = pred.detach().cpu().tolist()
        for i, (k, _, _) in enumerate(items):
            first.setdefault(k, abs(values[i] - labels[k]))
        return float(loss.detach()), [first[k] for k in range(len(batch))]

    def learn_from(self, t: Transition) -> float:
        """Store the transition in its prioritised replay and take one gradient step on it batched with replayed
        ones (priorities updated from the new TD errors); the loss, 0.0 for a primitive this stage does not train."""
        if t.primitive not in self.replay:
            return 0.0
        buf = self.replay[t.primitive]
        picks = [i for i in (buf.sample(self.rng) for _ in range(self.cfg.replay_samples)) if i is not None]
        loss, tds = self.learn([t] + [buf.get(i) for i in picks])
        buf.add(t, tds[0])
        for i, td in zip(picks, tds[1:], strict=True):
            buf.update_priority(i, td)
        return loss

    # -- the run -----------------------------------------------------------------------------------------------
    def weights(self) -> StateDicts:
        """The nets' state dicts on the CPU (what collectors act with)."""
        return {r: {k: v.detach().cpu() for k, v in n.state_dict().items()} for r, n in self.nets.items()}

    def _source(self) -> Source:
        if self.collector is not None:
            return LocalCollector(self.collector)
        from pg_learning.training.ray_collectors import RayCollectors  # imports Ray: only when collectors > 0

        return RayCollectors(self.cfg, self.cfg.collectors, self.cfg.ray_address, weights=self.weights(),
                             iteration=self.iteration, first_episode=self.episode)

    def _log_fields(self) -> list[str]:
        """LOG_FIELDS, or the header of an existing log.csv of an earlier version (its rows keep its columns)."""
        if self.log_.exists() and self.log_.stat().st_size > 0:
            with self.log_.open(newline="") as f:
                return next(csv.reader(f), LOG_FIELDS)
        return LOG_FIELDS

    def run(self) -> Path:
        """Train until cfg.iterations (or cfg.minutes); returns the checkpoint. Ctrl-C saves a checkpoint of the
        learner between two updates and re-raises KeyboardInterrupt: transitions in flight in the collectors (and
        the serial collector's unfinished action) are lost, the run resumes from the checkpoint."""
        from tqdm import tqdm

        cfg = self.cfg
        new_log = not self.log_.exists() or self.log_.stat().st_size == 0  # empty: a run stopped before its 1st row
        fields = self._log_fields()
        start, wall0 = self.iteration, time.perf_counter()
        recent: list[int] = []
        source = self._source()
        with source, self.log_.open("a", newline="") as f:
            writer = csv.DictWriter(f, fieldnames=fields, extrasaction="ignore")
            if new_log:
                writer.writeheader()
            bar = tqdm(total=cfg.iterations, initial=self.iteration, desc=f"train {self.stage.name}", unit="it")
            try:
                while self.iteration < cfg.iterations:
                    if cfg.minutes and time.perf_counter() - wall0 > cfg.minutes * 60:
                        print(f"[train] wall-clock budget of {cfg.minutes} min reached")
                        break
                    transition, row, index = source.next(self.iteration)
                    with _deferred_interrupt():  # one update, its log row, checkpoint and broadcast: all or none
                        row.update(iteration=self.iteration, loss=round(self.learn_from(transition), 5),
                                   wall_s=round(time.perf_counter() - wall0, 1), collector=index)
                        writer.writerow(row)
                        self.episode = max(self.episode, int(row["episode"]))
                        if row["primitive"] == "grasp":
                            recent = (recent + [row["success"]])[-100:]
                        self.iteration += 1
                        bar.update(1)
                        bar.set_postfix(grasp_success=f"{np.mean(recent):.2f}" if recent else "-",
                                        eps=row["epsilon"])
                        if self.iteration % cfg.checkpoint_every == 0:
                            f.flush()
                            self.save()
                        if self.iteration % cfg.weights_every == 0:
                            source.broadcast(self.weights(), self.iteration)
            except KeyboardInterrupt:
                f.flush()
                print(f"[train] interrupted: checkpoint at iteration {self.iteration}: {self.save()}")
                raise
            finally:
                bar.close()
        path = self.save()

        plot_curves(self.log_, self.dir / "curves.png",
                    title=f"{self.stage.name} ({cfg.backbone}, goal input: {cfg.goal})")
        (self.dir / "summary.json").write_text(json.dumps(
            {"stage": self.stage.name, "iterations": self.iteration, "this_run": self.iteration - start,
             "recent_grasp_success": float(np.mean(recent)) if recent else None}, indent=2))
        return path


@contextmanager
def _deferred_interrupt() -> Iterator[None]:
    """Ctrl-C (SIGINT) inside the block is held until its end, then handled as before the block (Python's default:
    KeyboardInterrupt), so it never stops the learner half-way through an update (a checkpoint then saves a
    consistent state). A no-op outside the main thread (signals go to the main thread) and where SIGINT is ignored
    (e.g. a background job) or handled outside Python."""
    previous = signal.getsignal(signal.SIGINT)
    if threading.current_thread() is not threading.main_thread() or previous in (None, signal.SIG_IGN):
        yield
        return
    caught: list[int] = []
    signal.signal(signal.SIGINT, lambda signum, frame: caught.append(signum))
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)
    if caught:
        if callable(previous):
            previous(signal.SIGINT, None)
        raise KeyboardInterrupt
