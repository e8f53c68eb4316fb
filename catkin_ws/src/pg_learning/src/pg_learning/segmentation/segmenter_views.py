"""Simulated views for training the click-conditioned segmenter: first observations of generated scenes with the
simulator's ground truth of which object each heightmap cell shows.

`collect(families, seed, count, out)` drops `count` scenes, cycling through `families` and the colour variants
COLOUR_CYCLE (unique, repeated, same: the net must not lean on colour to tell objects apart), scene k from seed
`seed + k`, and writes each as `<out>/<family>_<seed>_<colours>.npz`: color (H, W, 3) uint8, height (H, W) float32 m,
valid (H, W) bool, labels (H, W) int32 (the PyBullet body id seen at the top of each cell, -1 none), objects (N,)
int32 (the scene's object body ids), target int32 (the scene's target body id). A file already there is kept (a
rerun resumes). The default families are training families only; their seeds (SEED, below 1,000,000) are disjoint
from the evaluation's.
"""

from __future__ import annotations

import sys
from collections.abc import Sequence
from pathlib import Path

import numpy as np
from tqdm import tqdm

from pg_sim.world.recolour import REPEATED, SAME, UNIQUE

FAMILIES = ("train-household-10", "train-household-hard-8", "train-novel-10", "train-novel-packed-10",
            "train-mixed-10", "random-15", "dense-15")
COLOUR_CYCLE = (UNIQUE, REPEATED, SAME)
SEED = 300_000  # the first view's seed: training seeds, disjoint from the evaluation's (1,000,000 + i)


def view_name(family: str, seed: int, colours: str) -> str:
    return f"{family}_{seed}_{colours}.npz"


def collect(families: Sequence[str], seed: int, count: int, out: str | Path) -> list[Path]:
    """Write `count` views (module docstring) under `out`; returns their paths. A scene that fails to generate is
    reported on stderr and skipped (its file is not written)."""
    from pg_learning.environment.sim_env import SimEnv  # the simulator, loaded only when views are made

    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    envs: dict[str, SimEnv] = {}
    paths = []
    try:
        for k in tqdm(range(count), desc="views", unit="view"):
            family, colours = families[k % len(families)], COLOUR_CYCLE[(k // len(families)) % len(COLOUR_CYCLE)]
            path = out / view_name(family, seed + k, colours)
            if path.exists():
                paths.append(path)
                continue
            env = envs.setdefault(colours, SimEnv(colours=colours))
            try:
                env.reset(family, seed + k)
            except Exception as exc:  # one bad scene never ends the collection: it is said and skipped
                print(f"view {family} seed {seed + k}: {type(exc).__name__}: {exc}", file=sys.stderr)
                continue
            obs = env.world.observe()
            labels = env.world.label_heightmap(obs.frame)
            hm = obs.heightmap
            np.savez_compressed(path, color=hm.color, height=np.asarray(hm.height, np.float32), valid=hm.valid,
                                labels=labels.astype(np.int32), objects=np.array(sorted(env.world.objects), np.int32),
                                target=np.int32(-1 if env.world.target_id is None else env.world.target_id))
            paths.append(path)
    finally:
        for env in envs.values():
            env.close()
    return paths
