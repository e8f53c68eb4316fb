"""The one check of a user's `--device` string, shared by train, offline, eval and bench."""

from __future__ import annotations

from typing import Any


def check_device(name: str) -> Any:
    """torch.device(name) for cpu or an existing CUDA device. Raises ValueError for a string torch does not parse,
    another device type, or a CUDA device this machine does not have."""
    import torch

    try:
        dev = torch.device(name)
    except RuntimeError as e:
        raise ValueError(f"--device {name!r}: not a torch device ({e})") from e
    if dev.type == "cuda" and not (torch.cuda.is_available() and (dev.index or 0) < torch.cuda.device_count()):
        count = torch.cuda.device_count()
        seen = f"only {count} CUDA device(s)" if count else "no CUDA device"
        raise ValueError(f"--device {name!r}: torch sees {seen} on this machine")
    if dev.type not in ("cpu", "cuda"):
        raise ValueError(f"--device {name!r}: only cpu and cuda are supported")
    return dev
