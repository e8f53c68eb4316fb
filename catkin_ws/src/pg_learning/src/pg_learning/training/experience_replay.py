"""Prioritised experience replay on disk-backed arrays, so an interrupted run resumes with its experience.

A transition holds the observation before the action (colour uint8 (H, W, 3), height float16 (H, W) metres,
goal mask bool (H, W)), the action (primitive, rotation, row, col), the reward and, for pushes, the observation after
(for the bootstrapped target). Sampling is proportional to (|TD error| + eps) ** alpha (Schaul et al. 2016), the
"surprise" prioritisation of VPG and the paper.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np

PRIMITIVES = ("grasp", "push")


@dataclass(frozen=True)
class Transition:
    color: np.ndarray  # (H, W, 3) uint8
    height: np.ndarray  # (H, W) float metres
    mask: np.ndarray  # (H, W) bool goal mask
    primitive: str
    rotation: int
    row: int
    col: int
    reward: float
    next_color: np.ndarray | None = None  # pushes only
    next_height: np.ndarray | None = None
    next_mask: np.ndarray | None = None
    done: bool = True


class ReplayBuffer:
    """Fixed-capacity ring buffer in `directory` (numpy memmaps + meta.json); reopened as-is when it exists."""

    def __init__(self, directory: Path, capacity: int, shape: tuple[int, int], alpha: float = 0.6,
                 eps: float = 0.01) -> None:
        self.dir_ = Path(directory)
        self.dir_.mkdir(parents=True, exist_ok=True)
        self.alpha_, self.eps_ = alpha, eps
        meta_path = self.dir_ / "meta.json"
        meta = json.loads(meta_path.read_text()) if meta_path.exists() else None
        if meta and (meta["capacity"] != capacity or tuple(meta["shape"]) != tuple(shape)):
            raise ValueError(f"replay buffer in {self.dir_} has capacity {meta['capacity']} and shape {meta['shape']},"
                             f" not {capacity} and {list(shape)}: use another run directory")
        self.capacity, self.shape = capacity, tuple(shape)
        mode = "r+" if meta else "w+"
        h, w = shape
        self.arrays_ = {
            name: np.lib.format.open_memmap(self.dir_ / f"{name}.npy", mode=mode, dtype=dtype, shape=shp)
            for name, dtype, shp in [
                ("color", np.uint8, (capacity, h, w, 3)), ("height", np.float16, (capacity, h, w)),
                ("mask", np.bool_, (capacity, h, w)), ("next_color", np.uint8, (capacity, h, w, 3)),
                ("next_height", np.float16, (capacity, h, w)), ("next_mask", np.bool_, (capacity, h, w)),
                ("action", np.int32, (capacity, 4)), ("reward", np.float32, (capacity,)),
                ("done", np.bool_, (capacity,)), ("priority", np.float32, (capacity,)),
            ]
        }
        self.size = int(meta["size"]) if meta else 0
        self.next_ = int(meta["next"]) if meta else 0

    def __len__(self) -> int:
        return self.size

    def add(self, t: Transition, priority: float | None = None) -> int:
        """Store a transition (new ones get the current max priority unless given); returns its index."""
        i, a = self.next_, self.arrays_
        a["color"][i], a["height"][i], a["mask"][i] = t.color, t.height, t.mask
        if t.next_color is not None:
            a["next_color"][i], a["next_height"][i], a["next_mask"][i] = t.next_color, t.next_height, t.next_mask
        a["action"][i] = (PRIMITIVES.index(t.primitive), t.rotation, t.row, t.col)
        a["reward"][i], a["done"][i] = t.reward, t.done
        top = float(a["priority"][: self.size].max()) if self.size else 1.0
        a["priority"][i] = priority if priority is not None else max(top, self.eps_)
        self.next_ = (i + 1) % self.capacity
        self.size = min(self.size + 1, self.capacity)
        return i

    def sample(self, rng: np.random.Generator, primitive: str | None = None) -> int | None:
        """Index drawn with probability ~ priority ** alpha (optionally of one primitive); None if empty."""
        idx = np.arange(self.size)
        if primitive is not None:
            idx = idx[self.arrays_["action"][: self.size, 0] == PRIMITIVES.index(primitive)]
        if len(idx) == 0:
            return None
        p = (self.arrays_["priority"][idx].astype(np.float64) + self.eps_) ** self.alpha_
        return int(rng.choice(idx, p=p / p.sum()))

    def get(self, i: int) -> Transition:
        a = self.arrays_
        kind, rot, row, col = (int(v) for v in a["action"][i])
        push = PRIMITIVES[kind] == "push"
        return Transition(
            color=np.array(a["color"][i]), height=a["height"][i].astype(np.float32), mask=np.array(a["mask"][i]),
            primitive=PRIMITIVES[kind], rotation=rot, row=row, col=col, reward=float(a["reward"][i]),
            next_color=np.array(a["next_color"][i]) if push else None,
            next_height=a["next_height"][i].astype(np.float32) if push else None,
            next_mask=np.array(a["next_mask"][i]) if push else None, done=bool(a["done"][i]),
        )

    def filled(self, primitive: str) -> dict[str, np.ndarray]:
        """Copies of the stored transitions of one primitive, {field: (N, ...) array} in storage order: colour,
        height, mask, action, reward, and for pushes next_colour/height/mask and done (grasps have no next)."""
        a, n = self.arrays_, self.size
        rows = np.nonzero(a["action"][:n, 0] == PRIMITIVES.index(primitive))[0]
        names = ["color", "height", "mask", "action", "reward"]
        if primitive == "push":
            names += ["next_color", "next_height", "next_mask", "done"]
        return {name: np.asarray(a[name][rows]) for name in names}

    def update_priority(self, i: int, td_error: float) -> None:
        self.arrays_["priority"][i] = abs(td_error) + self.eps_

    def flush(self) -> None:
        """Write arrays and the ring state to disk (called at checkpoints)."""
        for arr in self.arrays_.values():
            arr.flush()
        meta = {"capacity": self.capacity, "shape": list(self.shape), "size": self.size, "next": self.next_}
        tmp = self.dir_ / "meta.json.tmp"
        tmp.write_text(json.dumps(meta))
        tmp.replace(self.dir_ / "meta.json")
