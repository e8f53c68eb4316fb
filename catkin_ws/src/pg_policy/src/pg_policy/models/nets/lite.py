"""A small CPU-trainable fully-convolutional trunk with the DenseNet trunk's interface.

Input (B, 3, H, W) float32 (normalised), output (B, `out_channels`, H/s, W/s) float32 for H, W multiples of s, the
output stride s = 16 (backbone `lite`) or 8 (`lite-os8`). Stages (conv-BN-ReLU): 4x4/4 patchify stem, two 3x3/2
downsamplers, then two 3x3/1 convs (the last dilated 2) at stride 16; receptive field 124 px (0.25 m at
0.002 m/px), ~0.14 M parameters. Scriptable with ``torch.jit.script``.

Output stride 8 is the same function sampled twice as densely (the atrous trick of DeepLab, Chen et al. 2017):
the second downsampler keeps stride 1 and the later convs double their dilation, so the parameters are the same
and a `lite` state_dict loads unchanged. `QNet` places cell j's value at 16 j + 7.5 px (stride 16) or
8 j + 3.5 px (stride 8); a `lite` cell's receptive field is centred 6 px before that (16 j + 1.5). The input
is shifted by 4 px at stride 8 so that every cell keeps these 6 px. Then trunk_os8(x)[..., ::2, ::2] ==
trunk_lite(x shifted by 4 px), and a `lite` model's Q is sampled on an 8 px (16 mm) grid instead of 16 px.
"""

from __future__ import annotations

import torch.nn.functional as F  # noqa: N812
from torch import Tensor, nn


def _stage(cin: int, cout: int, kernel: int, stride: int, dilation: int = 1) -> nn.Sequential:
    pad = 0 if kernel == stride else dilation * (kernel - 1) // 2
    return nn.Sequential(
        nn.Conv2d(cin, cout, kernel, stride=stride, padding=pad, dilation=dilation, bias=False),
        nn.BatchNorm2d(cout),
        nn.ReLU(inplace=True),
    )


class LiteTrunk(nn.Module):
    """Five conv-BN-ReLU stages, output stride `output_stride` (16 or 8), `out_channels` = widths[-1].
    Raises ValueError for another output stride."""

    def __init__(self, widths: tuple[int, int, int, int, int] = (16, 32, 64, 64, 128), output_stride: int = 16) -> None:
        super().__init__()
        if output_stride not in (8, 16):
            raise ValueError(f"lite trunk: output stride must be 8 or 16, not {output_stride}")
        dense = output_stride == 8
        w = widths
        self.out_channels = w[4]
        self.stride = output_stride
        self.shift = 4 if dense else 0  # px added at the top/left of the input (see the module docstring)
        # Window crops with at least this margin (px) give the full map's Q (receptive field of an output cell:
        # [16 j - 60, 16 j + 63] px at stride 16, [8 j - 64, 8 j + 59] px at stride 8, plus the two cells a
        # bilinear sample reads).
        self.exact_margin = 88
        self.features = nn.Sequential(
            _stage(3, w[0], 4, 4),  # /4
            _stage(w[0], w[1], 3, 2),  # /8
            _stage(w[1], w[2], 3, 1 if dense else 2),  # /16 (stride 16) or /8
            _stage(w[2], w[3], 3, 1, dilation=2 if dense else 1),
            _stage(w[3], w[4], 3, 1, dilation=4 if dense else 2),
        )
        for m in self.modules():
            if isinstance(m, nn.Conv2d):
                nn.init.kaiming_normal_(m.weight, nonlinearity="relu")
            elif isinstance(m, nn.BatchNorm2d):
                nn.init.constant_(m.weight, 1.0)
                nn.init.constant_(m.bias, 0.0)

    def forward(self, x: Tensor) -> Tensor:
        """(B, 3, H, W) float32 -> (B, out_channels, H/s, W/s) float32, s = `stride`."""
        if self.shift > 0:
            x = F.pad(x, (self.shift, 0, self.shift, 0))[:, :, : x.shape[2], : x.shape[3]]
        return self.features(x)
