"""Training curves from a run's log.csv: grasp success (and push reward) vs iteration, like the paper's Fig. 4."""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np


def rolling(values: np.ndarray, window: int) -> np.ndarray:
    """Trailing mean over up to `window` samples."""
    c = np.cumsum(np.insert(values.astype(np.float64), 0, 0.0))
    idx = np.arange(1, len(values) + 1)
    lo = np.maximum(idx - window, 0)
    return (c[idx] - c[lo]) / (idx - lo)


def plot_curves(log: Path, out: Path, title: str = "", window: int = 200) -> Path:
    """Write a PNG with the rolling grasp success rate (and push success where pushes were logged)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    with Path(log).open() as f:
        rows = list(csv.DictReader(f))
    fig, ax = plt.subplots(figsize=(8, 4.5), dpi=100)
    for prim, color in (("grasp", "tab:green"), ("push", "tab:blue")):
        sel = [r for r in rows if r["primitive"] == prim]
        if not sel:
            continue
        it = np.array([int(r["iteration"]) for r in sel])
        ok = np.array([int(r["success"]) for r in sel])
        ax.plot(it, rolling(ok, window), color=color, label=f"{prim} success (last {window} {prim}s)")
    ax.set_xlabel("iteration")
    ax.set_ylabel("success rate")
    ax.set_ylim(0, 1)
    ax.grid(alpha=0.3)
    ax.legend(loc="lower right")
    ax.set_title(title or str(log))
    fig.tight_layout()
    out = Path(out)
    fig.savefig(out)
    plt.close(fig)
    return out
