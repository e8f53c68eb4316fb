"""Loading training checkpoints (`last.pt` of a run's stage) without running pickled code.

A checkpoint holds tensors and plain values only (nets' and optimisers' state dicts, counters, the numpy RNG state,
the config as strings), so it loads with `torch.load(weights_only=True)`: a file that carries any other pickled
object is refused instead of executed.
"""

from __future__ import annotations

import pickle
from pathlib import Path
from typing import Any

import torch


def load_checkpoint(path: str | Path) -> dict[str, Any]:
    """The checkpoint at `path` on the CPU. Raises FileNotFoundError for a missing file and ValueError naming the
    file for one that is corrupt or holds anything but tensors and plain values."""
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"checkpoint not found: {path}")
    try:
        ck = torch.load(path, map_location="cpu", weights_only=True)
    except (pickle.UnpicklingError, RuntimeError, EOFError) as exc:
        first = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        raise ValueError(f"{path}: not a loadable training checkpoint (tensors and plain values only): {first}") \
            from None
    if not isinstance(ck, dict) or "nets" not in ck:
        raise ValueError(f"{path}: not a training checkpoint (no 'nets')")
    return ck
