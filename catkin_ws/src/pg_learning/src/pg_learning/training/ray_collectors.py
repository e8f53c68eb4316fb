"""Collectors as Ray actors: N processes (on this machine or a cluster's nodes) play episodes in parallel and stream
their transitions to the learner (`pushgrasp train --collectors N [--ray-address ...]`).

What runs where: the learner (`pg_learning.training.trainer.Trainer`: nets, optimisers, replay, checkpoints, log.csv)
stays in the `pushgrasp train` process, on the CPU or `--device cuda`; each collector actor (one CPU of the cluster,
torch on one thread) owns a simulator and CPU copies of the two nets (`pg_learning.training.collector.Collector`).
Every collector has exactly one `step` in flight; `next()` hands over whichever finishes first and gives that
collector its next step at once, so the simulators never wait for the learner's gradient step.

Weights: the learner `broadcast`s its state dicts every `weights_every` updates (one `ray.put`, ~1-5 MB for the lite
nets, then one `set_weights` call per actor). Ray runs an actor's calls in submission order, so a step submitted after
a broadcast acts with those weights. Off-policy lag: a step starts with weights at most weights_every - 1 updates
old, and the learner makes one update per transition that arrives while it runs (N - 1 with N equally fast
collectors; more from a collector slower than the others), so a transition is learned about weights_every + N updates
after the weights it was acted with. A larger weights_every sends fewer puts but acts with staler policies.

Failures: a collector that dies (its actor or its node) is restarted once per slot, from the latest broadcast
weights, with a message; a second death of the same slot raises RuntimeError naming the reason. Every wait is
bounded: no transition for `timeout_s` raises TimeoutError (e.g. a cluster without free CPUs for the actors).
Ray is imported only here, so the serial loop never loads it.
"""

from __future__ import annotations

import dataclasses
import time
from contextlib import ExitStack
from typing import Any

import numpy as np
import torch

from pg_learning.cluster.ray_session import ray_session
from pg_learning.training.collector import Collector
from pg_learning.training.config import TrainConfig
from pg_learning.training.experience_replay import Transition

COLLECTOR_TIMEOUT_S = 600.0  # no transition from any collector for this long: give up (actors start in ~10-30 s)
POLL_S = 1.0  # longest single wait, so that Ctrl-C is seen promptly

StateDicts = dict[str, dict[str, torch.Tensor]]


class CollectorActor:
    """A Collector in a Ray worker process (wrapped by `ray.remote` at run time): torch on one thread, CPU nets
    holding `weights` (of learner `iteration`) from the start."""

    def __init__(self, cfg: TrainConfig, index: int, count: int, first_episode: int, weights: StateDicts,
                 iteration: int) -> None:
        torch.set_num_threads(1)
        self.collector = Collector(cfg, index, count, first_episode)
        self.collector.set_weights(weights, iteration)

    def step(self, iteration: int) -> tuple[Transition, dict[str, Any]]:
        return self.collector.step(iteration)

    def set_weights(self, weights: StateDicts, iteration: int) -> None:
        self.collector.set_weights(weights, iteration)


def _owned(t: Transition) -> Transition:
    """`t` with writable arrays of its own (Ray hands out read-only views of its object store)."""
    return dataclasses.replace(t, **{f.name: np.array(getattr(t, f.name)) for f in dataclasses.fields(t)
                                     if isinstance(getattr(t, f.name), np.ndarray)})


class RayCollectors:
    """`n` collector actors on a local Ray of n + 1 CPUs (`address` None; the extra CPU is for the learner's own
    process, which takes none) or on the cluster at `address` ("auto" or HOST:PORT). They start from `weights` of
    learner `iteration` and number their episodes after `first_episode` (collector c of n: first_episode + c + 1,
    + n, ...). A context manager: leaving it kills the actors and leaves Ray (a local Ray ends)."""

    def __init__(self, cfg: TrainConfig, n: int, address: str | None, *, weights: StateDicts, iteration: int = 0,
                 first_episode: int = 0, timeout_s: float = COLLECTOR_TIMEOUT_S) -> None:
        if n < 1:
            raise ValueError(f"RayCollectors needs at least one collector, got {n}")
        import ray

        self.ray, self.cfg, self.n, self.timeout_s = ray, cfg, n, timeout_s
        self.first_episode = first_episode
        self.actors: list[Any] = []
        self.pending: dict[Any, int] = {}  # ObjectRef of the step in flight -> collector slot
        self.last_episode = [first_episode + c + 1 - n for c in range(n)]  # per slot, as the rows report them
        self.restarts = [0] * n
        self._stack = ExitStack()
        self.info = self._stack.enter_context(ray_session(n + 1, address))
        try:
            self._remote = ray.remote(num_cpus=1)(CollectorActor)
            self._weights_ref, self._weights_iteration = ray.put(weights), iteration
            for c in range(n):
                self.actors.append(self._start(c, first_episode))
                self._submit(c, iteration)
        except BaseException:
            self.close()
            raise
        print(f"[train] {n} collector(s) on Ray ({self.info.address}: {self.info.nodes} node(s), "
              f"{self.info.cpus} CPUs)")

    def __enter__(self) -> RayCollectors:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def _start(self, slot: int, first_episode: int) -> Any:
        return self._remote.remote(self.cfg, slot, self.n, first_episode, self._weights_ref, self._weights_iteration)

    def _submit(self, slot: int, iteration: int) -> None:
        self.pending[self.actors[slot].step.remote(iteration)] = slot

    def next(self, iteration: int) -> tuple[Transition, dict[str, Any], int]:
        """The next finished (transition, log row, collector slot); that collector's next step is submitted at once,
        at learner `iteration` (the epsilon schedule's clock). Restarts a dead collector once (module docstring);
        raises TimeoutError when no collector delivers for `timeout_s` seconds."""
        ray = self.ray
        deadline = time.monotonic() + self.timeout_s
        while True:
            left = deadline - time.monotonic()
            if left <= 0:
                raise TimeoutError(f"no transition from the {self.n} collector(s) in {self.timeout_s:.0f} s: is the "
                                   f"Ray cluster ({self.info.address}) short of free CPUs (one per collector)?")
            ready, _ = ray.wait(list(self.pending), num_returns=1, timeout=min(left, POLL_S))
            if not ready:
                continue
            slot = self.pending.pop(ready[0])
            try:
                transition, row = ray.get(ready[0])
            except (ray.exceptions.RayActorError, ray.exceptions.ObjectLostError) as exc:
                self._restart(slot, exc, iteration)
                deadline = time.monotonic() + self.timeout_s  # the new actor needs its start-up time
                continue
            self._submit(slot, iteration)
            self.last_episode[slot] = max(self.last_episode[slot], int(row["episode"]))
            return _owned(transition), row, slot

    def _restart(self, slot: int, exc: Exception, iteration: int) -> None:
        reason = (str(exc).strip().splitlines() or [type(exc).__name__])[0]
        if self.restarts[slot] >= 1:
            raise RuntimeError(f"collector {slot} died a second time, giving up: {reason}") from exc
        self.restarts[slot] += 1
        print(f"[train] collector {slot} died ({reason}); restarting it with the weights of iteration "
              f"{self._weights_iteration}")
        try:
            self.ray.kill(self.actors[slot], no_restart=True)
        except Exception:  # noqa: BLE001 - already gone
            pass
        # continue the slot's numbering after its last reported episode (an episode whose first step was in flight
        # when it died was never learned from, and may be played again)
        self.actors[slot] = self._start(slot, self.last_episode[slot] - slot - 1 + self.n)
        self._submit(slot, iteration)

    def broadcast(self, state_dicts: StateDicts, iteration: int) -> None:
        """Send the learner's CPU state dicts of `iteration` to every collector: their steps submitted from now on
        act with them. Also the weights a restarted collector starts from."""
        self._weights_ref, self._weights_iteration = self.ray.put(state_dicts), iteration
        for actor in self.actors:
            actor.set_weights.remote(self._weights_ref, iteration)

    def close(self) -> None:
        """Kill the actors (their steps in flight are dropped) and leave Ray. Idempotent."""
        for actor in self.actors:
            try:
                self.ray.kill(actor, no_restart=True)
            except Exception:  # noqa: BLE001 - already gone or Ray already down
                pass
        self.actors, self.pending = [], {}
        self._stack.close()
