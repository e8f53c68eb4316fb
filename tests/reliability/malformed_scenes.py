"""Malformed scene files (DESIGN.md section 6 format), each derived from a valid base scene, plus the valid base
itself as the control case. Every case but the control must be refused by both the simulator and the CLI."""

from __future__ import annotations

import copy
from collections.abc import Callable
from pathlib import Path
from random import Random
from typing import Any

import yaml

CONTROL = "control-valid"
Scene = dict[str, Any]


def base_scene() -> Scene:
    """Three blocks around a green target, well inside the workspace."""
    return {"name": "reliability_base", "target": "green", "objects": [
        {"shape": "cube", "color": "green", "pose": [0.0, 0.0, 0.0225, 0.0, 0.0, 0.0], "target": True},
        {"shape": "rect", "color": "blue", "pose": [0.08, 0.0, 0.0225, 0.0, 0.0, 0.0]},
        {"shape": "cylinder", "color": "red", "pose": [-0.08, 0.05, 0.0225, 0.0, 0.0, 0.0]},
    ]}


def _edit(fn: Callable[[Scene], None]) -> Callable[[Random], str]:
    def make(_rng: Random) -> str:
        scene = copy.deepcopy(base_scene())
        fn(scene)
        return yaml.safe_dump(scene, sort_keys=False)
    return make


def _set(index: int, key: str, value: Any) -> Callable[[Scene], None]:
    def fn(scene: Scene) -> None:
        scene["objects"][index][key] = value
    return fn


def _many(n: int) -> Callable[[Scene], None]:
    def fn(scene: Scene) -> None:
        for i in range(n):
            x, y = -0.2 + 0.4 * (i % 25) / 24, -0.2 + 0.4 * (i // 25) / 24
            scene["objects"].append({"shape": "cube", "color": "gray", "size": [0.01, 0.01, 0.01],
                                     "pose": [x, y, 0.2 + 0.02 * (i % 7), 0.0, 0.0, 0.0], "name": f"extra_{i}"})
    return fn


CASES: dict[str, Callable[[Random], str | bytes]] = {
    CONTROL: _edit(lambda s: None),
    "bad-yaml": lambda _r: "name: broken\nobjects: [\n  - {shape: cube, color: green\n",
    "not-a-mapping": lambda _r: "- just\n- a list\n",
    "empty-file": lambda _r: "",
    "binary-garbage": lambda r: bytes(r.getrandbits(8) for _ in range(2048)),
    "no-objects": _edit(lambda s: s.pop("objects")),
    "missing-pose": _edit(lambda s: s["objects"][1].pop("pose")),
    "wrong-type-pose": _edit(_set(1, "pose", "here")),
    "wrong-type-size": _edit(_set(1, "size", "big")),
    "nan-pose": _edit(_set(1, "pose", [float("nan"), 0.0, 0.0225, 0.0, 0.0, 0.0])),
    "inf-size": _edit(_set(1, "size", [float("inf"), 0.045, 0.045])),
    "huge-size": _edit(_set(1, "size", [100.0, 100.0, 100.0])),
    "tiny-size": _edit(_set(1, "size", [1e-6, 1e-6, 1e-6])),
    "negative-size": _edit(_set(1, "size", [-0.045, 0.045, 0.045])),
    "huge-mass": _edit(_set(1, "mass", 1e9)),
    "far-pose": _edit(_set(1, "pose", [1000.0, 0.0, 0.0225, 0.0, 0.0, 0.0])),
    "target-outside": _edit(_set(0, "pose", [5.0, 5.0, 0.0225, 0.0, 0.0, 0.0])),
    "500-objects": _edit(_many(500)),
    "shared-target-colour": _edit(_set(1, "color", "green")),
    "unknown-shape": _edit(_set(1, "shape", "dodecahedron")),
    "unknown-mesh": _edit(lambda s: s["objects"][1].update({"shape": "mesh", "mesh": "no/such/mesh.obj"})),
    "mesh-outside-folders": _edit(lambda s: s["objects"][1].update({"shape": "mesh", "mesh": "/etc/passwd"})),
}


def write(name: str, folder: Path, seed: int) -> Path:
    """Write case `name` to folder/<name>.yaml; its path."""
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / f"{name}.yaml"
    text = CASES[name](Random(f"{seed}:{name}"))
    if isinstance(text, bytes):
        path.write_bytes(text)
    else:
        path.write_text(text, encoding="utf-8")
    return path
