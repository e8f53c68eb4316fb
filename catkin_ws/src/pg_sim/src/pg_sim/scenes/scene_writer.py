"""Writing scene files: a SceneSpec as the YAML of DESIGN.md section 6 (pg_sim.scenes.scene reads them back)."""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import yaml

from pg_sim.scenes.colors import color_name
from pg_sim.scenes.scene import SceneSpec


def scene_to_dict(scene: SceneSpec, base_dir: str | Path | None = None) -> dict[str, Any]:
    """The YAML mapping of a scene; mesh paths under ``base_dir`` are written relative to it."""
    objects = []
    for o in scene.objects:
        d: dict[str, Any] = {"name": o.name, "shape": o.shape}
        if o.mesh is not None:
            mesh = Path(o.mesh)
            if base_dir is not None and mesh.resolve().is_relative_to(Path(base_dir).resolve()):
                mesh = mesh.resolve().relative_to(Path(base_dir).resolve())
            d["mesh"] = str(mesh)
            if o.scale != (1.0, 1.0, 1.0):
                d["scale"] = float(o.scale[0]) if len(set(o.scale)) == 1 else [float(v) for v in o.scale]
        if o.size is not None:
            d["size"] = [float(v) for v in o.size]
        d["color"] = color_name(o.color) or [int(v) for v in o.color]
        d["pose"] = [float(v) for v in o.pose]
        if o.mass is not None:
            d["mass"] = float(o.mass)
        if o.friction is not None:
            d["friction"] = float(o.friction)
        if o.target:
            d["target"] = True
        objects.append(d)
    return {"name": scene.name, "target": scene.target, "family": scene.family, "objects": objects}


def save_scene(scene: SceneSpec, path: str | os.PathLike[str]) -> Path:
    """Write ``scene`` as YAML to ``path`` (folders made); ``load_scene`` of the file gives back an equal SceneSpec."""
    out = Path(path)
    out.parent.mkdir(parents=True, exist_ok=True)
    text = yaml.safe_dump(scene_to_dict(scene, out.parent), sort_keys=False, default_flow_style=None, width=120)
    out.write_text(text, encoding="utf-8")
    return out
