"""Export / load a Q net as a self-contained TorchScript file with its metadata embedded.

File = ``torch.jit.save`` zip of the scripted `QNet` (normalisation and rotations inside) plus the extra file
``pushgrasp.json``: format version, role ("grasp" | "push"), backbone, goal, rotations, heightmap geometry (resolution
m, bounds [[xmin, xmax], [ymin, ymax], [zmin, zmax]] m in `world`, rows, cols), thresholds, colour table
(name -> [r, g, b]), creation time (UTC ISO 8601), and training stage / iteration when given. Loading needs torch
only (no project source); the call convention of the loaded module is documented in `pg_policy.models.nets.qnet`.
"""

from __future__ import annotations

import json
import os
import time
from pathlib import Path
from typing import Any

import numpy as np
import torch
from torch import nn

from pg_core.geometry import Geometry
from pg_core.geometry import load as load_geometry
from pg_core.palette import PALETTE

METADATA_NAME = "pushgrasp.json"
FORMAT_VERSION = 1
ROLES = ("grasp", "push")
DEFAULT_THRESHOLDS = {"grasp_q": 1.8}  # DESIGN.md section 7: grasp when masked max Q_g exceeds it
REQUIRED = ("format", "role", "backbone", "goal", "rotations", "heightmap")


class ModelLoadError(ValueError):
    """A model file that is missing, corrupt, not ours, or made for another heightmap geometry."""


QNET_INTERFACE = ("rotate_inputs", "q_from_rotated", "num_rotations", "use_mask")  # what PolicyNets calls

def geometry_metadata(geometry: Geometry) -> dict[str, Any]:
    """The heightmap part of the metadata: resolution (m), bounds (3x2 m), rows, cols, rotations."""
    return {
        "resolution": float(geometry.heightmap.resolution),
        "bounds": np.asarray(geometry.workspace.bounds, dtype=float).tolist(),
        "rows": int(geometry.heightmap.rows),
        "cols": int(geometry.heightmap.cols),
        "rotations": int(geometry.heightmap.rotations),
    }


def _default_colors() -> dict[str, list[int]]:
    return {name: [int(v) for v in rgb] for name, rgb in PALETTE.items()}


def build_metadata(net: nn.Module, role: str, geometry: Geometry | None = None,
                   extra: dict[str, Any] | None = None) -> dict[str, Any]:
    """Metadata for `net`: its config (backbone, goal, rotations), `role`, the geometry (default: the current config),
    default thresholds and colour table, the creation time; `extra` overrides/extends (e.g. stage, iteration)."""
    if role not in ROLES:
        raise ValueError(f"role must be one of {ROLES}, got {role!r}")
    cfg = json.loads(str(net.config_json)) if hasattr(net, "config_json") else {}
    meta: dict[str, Any] = {
        "format": FORMAT_VERSION,
        "role": role,
        "backbone": cfg.get("backbone"),
        "goal": cfg.get("goal"),
        "rotations": cfg.get("rotations"),
        "heightmap": geometry_metadata(geometry or load_geometry()),
        "thresholds": dict(DEFAULT_THRESHOLDS),
        "colors": _default_colors(),
        "created": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()),
    }
    meta.update(extra or {})
    return meta


def export_qnet(net: nn.Module, path: str | Path, metadata: dict[str, Any],
                geometry: Geometry | None = None) -> Path:
    """Script `net` (a QNet, or an already scripted one) and save it to `path` with `metadata` embedded.

    `metadata` needs at least "role"; missing standard fields are filled by `build_metadata` (config of the net,
    current geometry, defaults), given ones win. Raises ValueError if the metadata contradicts the net's config or
    lacks a valid role. Written atomically (temp file + rename). Returns the path.
    """
    if "role" not in metadata:
        raise ValueError("export metadata needs 'role' ('grasp' or 'push')")
    meta = build_metadata(net, str(metadata["role"]), geometry, metadata)
    cfg = json.loads(str(net.config_json)) if hasattr(net, "config_json") else {}
    clash = {k: (meta.get(k), v) for k, v in cfg.items() if k in ("backbone", "goal", "rotations") and meta.get(k) != v}
    if clash:
        raise ValueError(f"export metadata contradicts the net's config (metadata, net): {clash}")
    missing = [k for k in REQUIRED if meta.get(k) is None]
    if missing:
        raise ValueError(f"export metadata lacks {missing} (and the net does not provide them)")
    was_training = net.training
    net.eval()
    scripted = net if isinstance(net, torch.jit.ScriptModule) else torch.jit.script(net)
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(path.name + ".tmp")
    torch.jit.save(scripted, str(tmp), _extra_files={METADATA_NAME: json.dumps(meta, indent=2, sort_keys=True)})
    os.replace(tmp, path)
    net.train(was_training)
    return path


def verify_geometry(meta: dict[str, Any], geometry: Geometry, where: str = "model") -> None:
    """Raise ModelLoadError unless the metadata's heightmap geometry equals `geometry`'s (resolution, bounds,
    rows, cols, rotations), naming every difference."""
    have, want = meta.get("heightmap") or {}, geometry_metadata(geometry)
    diffs = []
    for key, value in want.items():
        got = have.get(key)
        if key in ("resolution", "bounds"):
            same = got is not None and np.shape(got) == np.shape(value) and np.allclose(
                np.asarray(got, dtype=float), np.asarray(value, dtype=float), rtol=0.0, atol=1e-9)
        else:
            same = got == value
        if not same:
            diffs.append(f"{key}: model {got!r} vs config {value!r}")
    if meta.get("rotations") != want["rotations"]:
        diffs.append(f"net rotations: model {meta.get('rotations')!r} vs config {want['rotations']!r}")
    if diffs:
        raise ModelLoadError(f"{where} was made for another heightmap geometry than {geometry.path}: "
                             + "; ".join(diffs))


def load_qnet(path: str | Path, geometry: Geometry | None = None, check_geometry: bool = True,
              map_location: str | torch.device = "cpu") -> tuple[torch.jit.ScriptModule, dict[str, Any]]:
    """(scripted net in eval mode, metadata) from an exported file.

    Raises ModelLoadError for: a missing file; a file that is not a TorchScript zip (corrupt, truncated, a plain
    state_dict); missing or unreadable ``pushgrasp.json`` metadata or missing fields; and, when `check_geometry`,
    metadata whose heightmap geometry differs from `geometry` (default: the current geometry config).
    """
    path = Path(path)
    if not path.is_file():
        raise ModelLoadError(f"model file not found: {path}")
    extra = {METADATA_NAME: ""}
    try:
        module = torch.jit.load(str(path), map_location=map_location, _extra_files=extra)
    except Exception as exc:  # torch raises RuntimeError/ValueError/... for bad archives
        first = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        raise ModelLoadError(f"{path} is not a readable TorchScript model (corrupt or truncated?): {first}") from exc
    raw = extra[METADATA_NAME]
    if not raw:
        raise ModelLoadError(f"{path} has no {METADATA_NAME} metadata: it was not written by `pushgrasp export`")
    try:
        meta = json.loads(raw)
    except (json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise ModelLoadError(f"{path}: unreadable {METADATA_NAME} metadata: {exc}") from exc
    missing = [k for k in REQUIRED if not isinstance(meta, dict) or k not in meta]
    if missing:
        raise ModelLoadError(f"{path}: metadata lacks {missing}")
    if meta["format"] != FORMAT_VERSION:
        raise ModelLoadError(f"{path}: metadata format {meta['format']!r}, this version reads {FORMAT_VERSION}")
    if check_geometry:
        verify_geometry(meta, geometry or load_geometry(), str(path))
    lacking = [a for a in QNET_INTERFACE if not hasattr(module, a)]
    if lacking:
        raise ModelLoadError(f"{path} is not a pushgrasp Q network: the TorchScript module lacks {', '.join(lacking)}")
    module.eval()
    return module, meta

