"""A small CPU-trainable fully-convolutional trunk with the DenseNet trunk's interface.

Input (B, 3, H, W) float32 (normalised), output (B, `out_channels`, H/16, W/16) float32 for H, W multiples of 16.
Stages (conv-BN-ReLU): 4x4/4 patchify stem, two 3x3/2 downsamplers, then two 3x3/1 convs (the last dilated 2) at
stride 16; receptive field 124 px (0.25 m at 0.002 m/px), ~0.14 M parameters. Scriptable with ``torch.jit.script``.
"""

from __future__ import annotations

from torch import Tensor, nn


def _stage(cin: int, cout: int, kernel: int, stride: int, dilation: int = 1) -> nn.Sequential:
    pad = 0 if kernel == stride else dilation * (kernel - 1) // 2
    return nn.Sequential(
        nn.Conv2d(cin, cout, kernel, stride=stride, padding=pad, dilation=dilation, bias=False),
        nn.BatchNorm2d(cout),
        nn.ReLU(inplace=True),
    )


class LiteTrunk(nn.Module):
    """Five conv-BN-ReLU stages, total stride 16, `out_channels` = widths[-1]."""

    stride = 16
    # Window crops with at least this margin (px) give the full map's Q (receptive field of an output cell:
    # [16 j - 60, 16 j + 63] px, plus the two cells a bilinear sample reads).
    exact_margin = 88

    def __init__(self, widths: tuple[int, int, int, int, int] = (16, 32, 64, 64, 128)) -> None:
        super().__init__()
        w = widths
        self.out_channels = w[4]
        self.features = nn.Sequential(
            _stage(3, w[0], 4, 4),  # /4
            _stage(w[0], w[1], 3, 2),  # /8
            _stage(w[1], w[2], 3, 2),  # /16
            _stage(w[2], w[3], 3, 1),
            _stage(w[3], w[4], 3, 1, dilation=2),
        )
        for m in self.modules():
            if isinstance(m, nn.Conv2d):
                nn.init.kaiming_normal_(m.weight, nonlinearity="relu")
            elif isinstance(m, nn.BatchNorm2d):
                nn.init.constant_(m.weight, 1.0)
                nn.init.constant_(m.bias, 0.0)

    def forward(self, x: Tensor) -> Tensor:
        """(B, 3, H, W) float32 -> (B, out_channels, H/16, W/16) float32."""
        return self.features(x)
