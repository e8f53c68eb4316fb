"""The seed convention shared by training, evaluation and the scene tools (DESIGN.md section 8): training draws its
scenes from seeds below MIN_EVAL_SEED, evaluation from MIN_EVAL_SEED on, so no evaluation scene is a training scene.
"""

from __future__ import annotations

MIN_EVAL_SEED = 1_000_000  # the first evaluation seed; every training seed is below it


def is_eval_seed(seed: int) -> bool:
    """Whether `seed` lies in the evaluation range (>= MIN_EVAL_SEED)."""
    return int(seed) >= MIN_EVAL_SEED


def train_seed(run_seed: int, episode: int) -> int:
    """The scene seed of training episode `episode` of a run seeded `run_seed`: (run_seed * 100_003 + episode) mod
    MIN_EVAL_SEED, always a training seed; the collectors of one run number their episodes apart, so they play
    disjoint scenes."""
    return (int(run_seed) * 100_003 + int(episode)) % MIN_EVAL_SEED
