"""DenseNet-121 feature trunk with torchvision's module and parameter names (no torchvision needed).

`DenseNet121Trunk().state_dict()` has exactly the keys of torchvision's ``densenet121().state_dict()`` that start with
``features.`` (725 keys: parameters and BN buffers), so an ImageNet ``densenet121`` .pth loads with strict matching via
`load_pretrained`. Architecture (Huang et al. 2017): growth 32, blocks (6, 12, 24, 16), bn_size 4, 64 initial features.

Input (B, 3, H, W) float32 (already normalised), output (B, 1024, ceil-ish H/32, W/32) float32 after ``norm5`` (no
final ReLU, as in ``torchvision.models.densenet121().features``). Scriptable with ``torch.jit.script``.
"""

from __future__ import annotations

import re
from collections import OrderedDict
from pathlib import Path

import torch
from torch import Tensor, nn

GROWTH_RATE = 32
BLOCK_CONFIG = (6, 12, 24, 16)
NUM_INIT_FEATURES = 64
BN_SIZE = 4

# torchvision's legacy checkpoints name 'denselayer1.norm.1.weight' what is now 'denselayer1.norm1.weight'.
_LEGACY = re.compile(r"^(.*denselayer\d+\.(?:norm|relu|conv))\.((?:[12])\.(?:weight|bias|running_mean|running_var))$")


class PretrainedError(ValueError):
    """A pretrained weight file that is unreadable or does not match the trunk."""


class _DenseLayer(nn.Module):
    """BN-ReLU-conv1x1(bn_size*growth)-BN-ReLU-conv3x3(growth) on the concatenation of all previous features."""

    def __init__(self, in_ch: int, growth: int, bn_size: int) -> None:
        super().__init__()
        self.norm1 = nn.BatchNorm2d(in_ch)
        self.relu1 = nn.ReLU(inplace=True)
        self.conv1 = nn.Conv2d(in_ch, bn_size * growth, kernel_size=1, stride=1, bias=False)
        self.norm2 = nn.BatchNorm2d(bn_size * growth)
        self.relu2 = nn.ReLU(inplace=True)
        self.conv2 = nn.Conv2d(bn_size * growth, growth, kernel_size=3, stride=1, padding=1, bias=False)

    def forward(self, x: Tensor) -> Tensor:
        return self.conv2(self.relu2(self.norm2(self.conv1(self.relu1(self.norm1(x))))))


class _DenseBlock(nn.ModuleDict):
    """`n` dense layers named denselayer1..n; output = input channels + n * growth."""

    def __init__(self, n: int, in_ch: int, growth: int, bn_size: int) -> None:
        super().__init__()
        for i in range(n):
            self.add_module(f"denselayer{i + 1}", _DenseLayer(in_ch + i * growth, growth, bn_size))

    def forward(self, x: Tensor) -> Tensor:
        features = [x]
        for _name, layer in self.items():
            features.append(layer(torch.cat(features, 1)))
        return torch.cat(features, 1)


class _Transition(nn.Sequential):
    """BN-ReLU-conv1x1-avgpool2: halves channels and resolution."""

    def __init__(self, in_ch: int, out_ch: int) -> None:
        super().__init__()
        self.norm = nn.BatchNorm2d(in_ch)
        self.relu = nn.ReLU(inplace=True)
        self.conv = nn.Conv2d(in_ch, out_ch, kernel_size=1, stride=1, bias=False)
        self.pool = nn.AvgPool2d(kernel_size=2, stride=2)


class DenseNet121Trunk(nn.Module):
    """``torchvision.models.densenet121().features`` under the attribute ``features``: stride 32, 1024 channels."""

    out_channels = 1024
    stride = 32
    exact_margin = -1  # receptive field 2071 px: a window crop is always an approximation

    def __init__(self) -> None:
        super().__init__()
        layers: OrderedDict[str, nn.Module] = OrderedDict(
            conv0=nn.Conv2d(3, NUM_INIT_FEATURES, kernel_size=7, stride=2, padding=3, bias=False),
            norm0=nn.BatchNorm2d(NUM_INIT_FEATURES),
            relu0=nn.ReLU(inplace=True),
            pool0=nn.MaxPool2d(kernel_size=3, stride=2, padding=1),
        )
        ch = NUM_INIT_FEATURES
        for i, n in enumerate(BLOCK_CONFIG):
            layers[f"denseblock{i + 1}"] = _DenseBlock(n, ch, GROWTH_RATE, BN_SIZE)
            ch += n * GROWTH_RATE
            if i != len(BLOCK_CONFIG) - 1:
                layers[f"transition{i + 1}"] = _Transition(ch, ch // 2)
                ch //= 2
        layers["norm5"] = nn.BatchNorm2d(ch)
        self.features = nn.Sequential(layers)
        assert ch == self.out_channels
        # torchvision's initialisation
        for m in self.modules():
            if isinstance(m, nn.Conv2d):
                nn.init.kaiming_normal_(m.weight)
            elif isinstance(m, nn.BatchNorm2d):
                nn.init.constant_(m.weight, 1.0)
                nn.init.constant_(m.bias, 0.0)

    def forward(self, x: Tensor) -> Tensor:
        """(B, 3, H, W) float32 -> (B, 1024, H', W') float32, H' = H/32 for H a multiple of 32."""
        return self.features(x)


def rename_legacy_keys(state: dict[str, Tensor]) -> dict[str, Tensor]:
    """Map torchvision's legacy 'denselayerN.norm.1.weight' keys to 'denselayerN.norm1.weight'; others unchanged."""
    out: dict[str, Tensor] = {}
    for key, value in state.items():
        m = _LEGACY.match(key)
        out[m.group(1) + m.group(2) if m else key] = value
    return out


def _read_state_dict(path: Path) -> dict[str, Tensor]:
    if not path.is_file():
        raise FileNotFoundError(f"pretrained DenseNet-121 weights not found: {path}")
    try:
        obj = torch.load(path, map_location="cpu", weights_only=True)
    except Exception as exc:  # pickle/zip errors come in many types
        raise PretrainedError(f"cannot read pretrained weights {path}: not a PyTorch state_dict file ({exc})") from exc
    if isinstance(obj, dict) and "state_dict" in obj and isinstance(obj["state_dict"], dict):
        obj = obj["state_dict"]
    if not isinstance(obj, dict) or not all(isinstance(v, Tensor) for v in obj.values()):
        raise PretrainedError(f"pretrained weights {path}: expected a state_dict (name -> tensor)")
    return obj


def load_pretrained(module: nn.Module, path: str | Path) -> None:
    """Load a torchvision densenet121 .pth into `module` (a `DenseNet121Trunk`, strict match of every key/shape).

    The file may hold the full classifier model (``classifier.*`` ignored), use legacy key names (and lack the
    ``num_batches_tracked`` buffers), or carry a ``module.`` prefix (DataParallel). Raises FileNotFoundError if
    missing, PretrainedError (a ValueError) if the file is corrupt or its keys/shapes do not match.
    """
    path = Path(path)
    state = rename_legacy_keys(_read_state_dict(path))
    state = {k.removeprefix("module."): v for k, v in state.items()}
    state = {k: v for k, v in state.items() if not k.startswith("classifier.")}
    expected = module.state_dict()
    for key in expected:  # checkpoints older than BatchNorm's num_batches_tracked buffer lack it
        if key.endswith(".num_batches_tracked") and key not in state:
            state[key] = torch.zeros((), dtype=torch.long)
    missing = sorted(set(expected) - set(state))
    unexpected = sorted(set(state) - set(expected))
    wrong = sorted(k for k in set(expected) & set(state) if tuple(expected[k].shape) != tuple(state[k].shape))
    if missing or unexpected or wrong:
        raise PretrainedError(
            f"pretrained weights {path} do not fit DenseNet-121 features: {len(missing)} missing "
            f"(e.g. {missing[:3]}), {len(unexpected)} unexpected (e.g. {unexpected[:3]}), "
            f"{len(wrong)} with wrong shapes (e.g. {wrong[:3]})"
        )
    module.load_state_dict(state, strict=True)

