"""Backbone registry: name -> how to build a trunk and how to load pretrained weights into it.

Every trunk maps (B, 3, H, W) float32 -> (B, out_channels, H / stride, W / stride) float32 and exposes the int
attributes `out_channels` and `stride` (a divisor of 32, see `pg_policy.models.nets.qnet.CANVAS_MULTIPLE`).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from functools import partial
from pathlib import Path

from torch import nn

from pg_policy.models.nets.densenet import DenseNet121Trunk
from pg_policy.models.nets.densenet import load_pretrained as densenet_load_pretrained
from pg_policy.models.nets.lite import LiteTrunk


def _no_pretrained(module: nn.Module, path: str | Path) -> None:
    raise ValueError(f"lite backbones have no pretrained weights (got pretrained={str(path)!r}); train from scratch")


@dataclass(frozen=True)
class Backbone:
    """build() -> a fresh trunk; load_pretrained(trunk, path) fills it (raises FileNotFoundError / ValueError)."""

    build: Callable[[], nn.Module]
    load_pretrained: Callable[[nn.Module, str | Path], None]
    description: str
    weights_of: tuple[str, ...] = ()  # other backbones whose trained weights this one takes unchanged


BACKBONES: dict[str, Backbone] = {
    "densenet121": Backbone(DenseNet121Trunk, densenet_load_pretrained,
                            "DenseNet-121 features (torchvision names), stride 32, 1024 ch, ~7.0 M params"),
    "lite": Backbone(LiteTrunk, _no_pretrained, "5 conv-BN-ReLU stages, stride 16, 128 ch, ~0.14 M params"),
    "lite-os8": Backbone(partial(LiteTrunk, output_stride=8), _no_pretrained,
                         "lite's parameters at output stride 8 (atrous): Q on a 16 mm grid", weights_of=("lite",)),
}


def get_backbone(name: str) -> Backbone:
    """The registry entry for `name`; raises ValueError listing the known names."""
    try:
        return BACKBONES[name]
    except KeyError:
        raise ValueError(f"unknown backbone {name!r}; known: {', '.join(sorted(BACKBONES))}") from None
