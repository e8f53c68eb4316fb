"""Corrupt model files for the policy node (`_policy:=FILE`): each case writes its file (or folder) and names what
must not happen besides the node starting (a pickle's payload leaving a marker file)."""

from __future__ import annotations

import io
import json
import pickle
import shutil
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from random import Random

REPO = Path(__file__).resolve().parents[2]
SHIPPED = REPO / "catkin_ws" / "src" / "pg_policy" / "models" / "lite"
METADATA = "pushgrasp.json"


@dataclass(frozen=True)
class ModelCase:
    name: str
    path: Path  # what is given as _policy
    marker: Path | None = None  # a file the payload would create if the node ran it


class _Payload:
    """Unpickling this calls open(marker, "w"): a file appears if anything unpickles it."""

    def __init__(self, marker: Path) -> None:
        self.marker = str(marker)

    def __reduce__(self) -> tuple[Callable[..., object], tuple[str, str]]:
        return open, (self.marker, "w")


def _shipped_metadata() -> str:
    import torch

    extra = {METADATA: ""}
    torch.jit.load(str(SHIPPED / "grasp.pt"), map_location="cpu", _extra_files=extra)
    return extra[METADATA]


def _script(path: Path, metadata: str | None) -> None:
    """A TorchScript file of a net that is not a Q net (one linear layer), with the given metadata text."""
    import torch
    from torch import nn

    class Wrong(nn.Module):
        def __init__(self) -> None:
            super().__init__()
            self.fc = nn.Linear(3, 1)

        def forward(self, x: torch.Tensor) -> torch.Tensor:
            return self.fc(x)

    extra = {METADATA: metadata} if metadata is not None else {}
    torch.jit.save(torch.jit.script(Wrong()), str(path), _extra_files=extra)


def build(name: str, folder: Path, seed: int) -> ModelCase:
    """Write the case `name` (one of CASES) under folder."""
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / f"{name}.pt"
    marker = folder / f"{name}.payload-ran"
    rng = Random(f"{seed}:{name}")
    if name == "missing":
        return ModelCase(name, folder / "no_such_model.pt")
    if name == "zero-byte":
        path.write_bytes(b"")
    elif name == "truncated":
        data = (SHIPPED / "grasp.pt").read_bytes()
        path.write_bytes(data[: len(data) // 2])
    elif name == "random-bytes":
        path.write_bytes(bytes(rng.getrandbits(8) for _ in range(65536)))
    elif name == "text":
        path.write_text("this is a text file, not a model\n")
    elif name == "pickle-code":
        import torch

        buf = io.BytesIO()
        torch.save(_Payload(marker), buf)
        path.write_bytes(buf.getvalue())
        return ModelCase(name, path, marker)
    elif name == "raw-pickle-code":
        path.write_bytes(pickle.dumps(_Payload(marker)))
        return ModelCase(name, path, marker)
    elif name == "wrong-arch":
        _script(path, _shipped_metadata())
    elif name == "no-metadata":
        _script(path, None)
    elif name == "bad-metadata":
        _script(path, "{not json")
    elif name == "wrong-metadata-format":
        meta = json.loads(_shipped_metadata())
        meta["format"] = 999
        _script(path, json.dumps(meta))
    elif name == "dir-bad-push":
        model_dir = folder / "dir_bad_push"
        model_dir.mkdir(exist_ok=True)
        shutil.copy(SHIPPED / "grasp.pt", model_dir / "grasp.pt")
        (model_dir / "push.pt").write_bytes(b"")
        return ModelCase(name, model_dir)
    else:
        raise ValueError(f"unknown model case {name!r}")
    return ModelCase(name, path)


CASES = ("missing", "zero-byte", "truncated", "random-bytes", "text", "pickle-code", "raw-pickle-code", "wrong-arch",
         "no-metadata", "bad-metadata", "wrong-metadata-format", "dir-bad-push")
