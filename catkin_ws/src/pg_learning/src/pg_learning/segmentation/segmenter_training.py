"""Training the click-conditioned object segmenter (pg_policy.models.nets.click_segmenter) on simulated views.

The views are those `segmenter_views.collect` saved: first observations of the training families with the
simulator's per-cell object ids. Each example is one object of one view: a click inside it (its innermost cell, as
`--target-by point` clicks, or a random cell at least 2 cells inside its border), the window of
`window` cells centred on the click, and the object's visible cells as the label. Augmented by the eight
rotations and flips of the grid and a brightness change. Loss: binary cross-entropy plus soft Dice. Adam.

`train(...)` checkpoints to `<out>/checkpoint.pt` every `checkpoint_every` steps and resumes from it; it writes the
TorchScript model `<out>/click_segmenter.pt` when done. Seeds: `seed` draws the examples and initialises the net.
"""

from __future__ import annotations

import math
import time
from dataclasses import asdict, dataclass, field
from pathlib import Path

import cv2
import numpy as np
import torch
from torch import nn

from pg_learning.segmentation.segmenter_views import FAMILIES
from pg_learning.segmentation.segmenter_views import SEED as VIEW_SEED
from pg_policy.models.nets.click_segmenter import ClickSegmenter, encode_window

MIN_CELLS = 30  # objects with fewer visible cells are not clicked
RANDOM_CLICK_DEPTH = 2.0  # a random click lies at least this many cells inside the object's border


def _f(default, help_text: str):
    return field(default=default, metadata={"help": help_text})


@dataclass(frozen=True)
class SegmenterTraining:
    """Arguments of `train` and of `pushgrasp train-segmenter` (one flag per field, its help the metadata)."""

    views: str = _f("runs/segmenter/views", "folder of view files (*.npz); `--collect` views are made there first")
    out: str = _f("runs/segmenter", "run folder: checkpoint.pt, log.txt, click_segmenter.pt (the TorchScript model)")
    collect: int = _f(1100, "views to drop and save first (cycling through --families and the colour variants; "
                            "views already saved are kept, so a rerun resumes)")
    families: str = _f(",".join(FAMILIES), "comma-separated scene families of the views (training families)")
    view_seed: int = _f(VIEW_SEED, "seed of the first view (view k: view_seed + k; below 1,000,000)")
    steps: int = _f(2000, "optimiser steps (0: collect the views only)")
    batch: int = _f(12, "examples (one clicked object each) per step")
    window: int = _f(128, "window size in cells (a multiple of 32): objects up to 25 cm across")
    lr: float = _f(1e-3, "Adam learning rate (cosine-decayed to 5 % over the steps)")
    seed: int = _f(0, "draws the examples and the initial weights")
    checkpoint_every: int = _f(250, "steps between checkpoints (a rerun resumes from the last)")
    held_out: float = _f(0.1, "share of the views (by seed: its last two digits under 100 x this) kept for "
                                 "validation, never trained on")
    threads: int = _f(2, "torch CPU threads")


@dataclass
class View:
    """One saved view: color (H, W, 3) uint8, height (H, W) float32 m, valid (H, W) bool, labels (H, W) int32 body
    ids (-1 none), objects: the object body ids."""

    color: np.ndarray
    height: np.ndarray
    valid: np.ndarray
    labels: np.ndarray
    objects: np.ndarray

    @staticmethod
    def load(path: Path) -> View:
        d = np.load(path)
        return View(d["color"], d["height"], d["valid"].astype(bool), d["labels"], d["objects"])

    def clickable(self) -> list[int]:
        """Object ids with at least MIN_CELLS visible cells."""
        return [int(b) for b in self.objects if int((self.labels == b).sum()) >= MIN_CELLS]


def innermost_cell(mask: np.ndarray, rng: np.random.Generator | None = None) -> tuple[int, int]:
    """A click in the (H, W) bool `mask`: its innermost cell nearest its centroid (rng None: where `--target-by
    point` clicks), or a random cell RANDOM_CLICK_DEPTH or more inside its border."""
    inside = cv2.distanceTransform(np.pad(mask, 1).astype(np.uint8), cv2.DIST_L2, 3)[1:-1, 1:-1]
    if rng is not None:
        rows, cols = np.nonzero(inside >= min(RANDOM_CLICK_DEPTH, float(inside.max())))
        k = int(rng.integers(len(rows)))
        return int(rows[k]), int(cols[k])
    rows, cols = np.nonzero(inside >= inside.max() - 1e-6)
    rr, cc = np.nonzero(mask)
    k = int(np.argmin((rows - rr.mean()) ** 2 + (cols - cc.mean()) ** 2))
    return int(rows[k]), int(cols[k])


def example(view: View, body: int, window: int, rng: np.random.Generator,
            augment: bool = True) -> tuple[np.ndarray, np.ndarray]:
    """(input (IN_CHANNELS, window, window) float32, label (window, window) float32) for object `body` of `view`."""
    mask = view.labels == body
    row, col = innermost_cell(mask, rng if rng.random() < 0.5 else None)
    x = encode_window(view.color, view.height, view.valid, row, col, window)
    half = window // 2
    y = np.zeros((window, window), np.float32)
    r0, c0 = row - half, col - half
    rs, re = max(r0, 0), min(r0 + window, mask.shape[0])
    cs, ce = max(c0, 0), min(c0 + window, mask.shape[1])
    y[rs - r0:re - r0, cs - c0:ce - c0] = mask[rs:re, cs:ce]
    if augment:
        k = int(rng.integers(4))
        x, y = np.rot90(x, k, axes=(1, 2)), np.rot90(y, k)
        if rng.random() < 0.5:
            x, y = x[:, :, ::-1], y[:, ::-1]
        x = x.copy()
        x[0:3] = np.clip(x[0:3] * rng.uniform(0.8, 1.2), 0.0, 1.0)
    return np.ascontiguousarray(x), np.ascontiguousarray(y)


def split(views: Path, held_out: float) -> tuple[list[Path], list[Path]]:
    """(training, validation) view files under `views`: a view validates when its seed's last two digits are under
    100 * held_out (every family and colour variant has some), never trained on."""
    files = sorted(views.rglob("*.npz"))
    if not files:
        raise FileNotFoundError(f"no view files (*.npz) under {views}")
    val = [f for f in files if int(f.stem.split("_")[-2]) % 100 < round(100 * held_out)]
    return [f for f in files if f not in set(val)], val


def loss_fn(logits: torch.Tensor, target: torch.Tensor) -> torch.Tensor:
    """Binary cross-entropy plus soft Dice of (B, 1, S, S) logits against (B, 1, S, S) {0, 1} targets."""
    bce = nn.functional.binary_cross_entropy_with_logits(logits, target)
    p = torch.sigmoid(logits)
    inter = (p * target).sum(dim=(1, 2, 3))
    dice = 1 - (2 * inter + 1) / (p.sum(dim=(1, 2, 3)) + target.sum(dim=(1, 2, 3)) + 1)
    return bce + dice.mean()


def train(args: SegmenterTraining) -> Path:
    """Train (resuming from <out>/checkpoint.pt) and write <out>/click_segmenter.pt; returns its path."""
    torch.set_num_threads(args.threads)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    train_files, _ = split(Path(args.views), args.held_out)
    views = [View.load(f) for f in train_files]
    items = [(k, b) for k, v in enumerate(views) for b in v.clickable()]
    torch.manual_seed(args.seed)
    net = ClickSegmenter()
    opt = torch.optim.Adam(net.parameters(), lr=args.lr)
    sched = torch.optim.lr_scheduler.LambdaLR(
        opt, lambda s: 0.05 + 0.95 * 0.5 * (1 + math.cos(math.pi * min(s, args.steps) / args.steps)))
    step, ckpt = 0, out / "checkpoint.pt"
    if ckpt.exists():
        state = torch.load(ckpt, weights_only=False)
        net.load_state_dict(state["net"])
        opt.load_state_dict(state["opt"])
        sched.load_state_dict(state["sched"])
        step = int(state["step"])
    rng = np.random.default_rng([args.seed, step])
    print(f"{len(views)} training views, {len(items)} objects; step {step} of {args.steps}", flush=True)
    t0, running = time.time(), []
    net.train()
    with open(out / "log.txt", "a") as log:
        while step < args.steps:
            picks = rng.integers(len(items), size=args.batch)
            pairs = [example(views[items[i][0]], items[i][1], args.window, rng) for i in picks]
            x = torch.from_numpy(np.stack([p[0] for p in pairs]))
            y = torch.from_numpy(np.stack([p[1] for p in pairs]))[:, None]
            loss = loss_fn(net(x), y)
            opt.zero_grad()
            loss.backward()
            opt.step()
            sched.step()
            step += 1
            running.append(loss.item())
            if step % 50 == 0 or step == args.steps:
                line = f"step {step}/{args.steps} loss {np.mean(running):.4f} ({time.time() - t0:.0f} s)"
                print(line, flush=True)
                log.write(line + "\n")
                running = []
            if step % args.checkpoint_every == 0 or step == args.steps:
                torch.save({"net": net.state_dict(), "opt": opt.state_dict(), "sched": sched.state_dict(),
                            "step": step, "args": asdict(args)}, ckpt)
    net.eval()
    path = out / "click_segmenter.pt"
    torch.jit.script(net).save(str(path))
    return path
