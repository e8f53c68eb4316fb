"""Exported models on disk for the learned policies: which files, their nets, the decision values they carry.

`pushgrasp export` writes a directory with grasp.pt and push.pt (TorchScript with embedded metadata,
pg_policy.models.model_io); the grasp net's metadata holds the decision values (thresholds.grasp_q,
thresholds.push_budget) and the rule list (pg_policy.decision.rules.registry.model_rules).
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

from pg_core.resources import shipped_models
from pg_policy.models.inference import PolicyNets
from pg_policy.models.model_io import ModelLoadError, load_qnet

GRASP_FILE = "grasp.pt"
PUSH_FILE = "push.pt"


def __getattr__(name: str) -> Any:
    if name == "SHIPPED_MODELS":  # pg_policy's models/ folder (pg_core.resources), found when first asked for
        return shipped_models()
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def resolve_models(paths: Sequence[str | Path], need_push: bool) -> tuple[Path, Path | None]:
    """(grasp model, push model or None) from a directory holding grasp.pt [+ push.pt] or from files (grasp first).

    Raises FileNotFoundError naming what is missing (push.pt only when `need_push`), ValueError for > 2 paths.
    """
    ps = [Path(p).expanduser() for p in paths]
    if not ps:
        raise FileNotFoundError("no model given: pass a directory with grasp.pt/push.pt or the model file(s)")
    if len(ps) > 2:
        raise ValueError(f"at most two model files (grasp, push), got {len(ps)}")
    if len(ps) == 1 and ps[0].is_dir():
        grasp, push = ps[0] / GRASP_FILE, ps[0] / PUSH_FILE
        if not grasp.is_file():
            raise FileNotFoundError(f"model directory {ps[0]} has no {GRASP_FILE} (write one with `pushgrasp export`)")
        if need_push and not push.is_file():
            raise FileNotFoundError(f"model directory {ps[0]} has no {PUSH_FILE}; the learned policy needs both nets "
                                    "(use --policy grasp-only for a grasp net alone)")
        return grasp, push if push.is_file() else None
    for p in ps:
        if not p.is_file():
            raise FileNotFoundError(f"model file not found: {p}")
    if need_push and len(ps) < 2:
        raise FileNotFoundError("the learned policy needs a push model too: pass grasp.pt and push.pt (or their dir)")
    return ps[0], ps[1] if len(ps) > 1 else None


def load_nets(grasp: Path, push: Path | None, device: str) -> Any:
    """pg_policy.models.inference.PolicyNets from exported files (the grasp net stands in for a missing push net,
    whose maps are then never asked for). Raises ModelLoadError (a ValueError) for bad files or another geometry."""

    if push is not None:
        return PolicyNets.from_files(grasp, push, device=device)
    net, meta = load_qnet(grasp, map_location=device)
    if meta.get("role") != "grasp":
        raise ModelLoadError(f"{grasp}: exported as the {meta.get('role')!r} net, expected 'grasp'")
    return PolicyNets(net, net, {"grasp": meta, "push": meta}, device)


def metadata_thresholds(metadata: Any) -> dict[str, Any]:
    """The decision values stored with a grasp model (metadata "thresholds", pg_policy.models.model_io); {} if
    none."""
    thresholds = metadata.get("thresholds") if isinstance(metadata, dict) else None
    return thresholds if isinstance(thresholds, dict) else {}


def threshold_from_metadata(metadata: Any) -> float:
    """The grasp threshold stored with a grasp model (metadata thresholds.grasp_q); ValueError when absent."""
    thresholds = metadata_thresholds(metadata)
    if "grasp_q" not in thresholds:
        raise ValueError("the grasp model's metadata holds no thresholds.grasp_q; pass --grasp-threshold")
    return float(thresholds["grasp_q"])
