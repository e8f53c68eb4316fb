"""Exact Q of a `lite` QNet on a window of heightmap cells, each layer computed only where the window needs it.

The lite trunk (pg_policy.models.nets.lite) is plain conv-BN-ReLU stages and the head is 1x1 convolutions, so an
output cell depends on a fixed box of the layer below. Working back from the head cells that the window's rotated-back
bilinear samples read, every stage is computed on the box its successor reads: a convolution without padding over
a crop whose positions outside the full canvas's feature map are zero, which are exactly the zeros the full
computation pads with. The window's Q is then the full map's (up to float rounding, ~1e-6) for any window, at a cost
that grows with the window's area instead of the canvas's: for the push region of a packed scene's target about a
third of the full map's multiply-adds, for its grasp region about a tenth. (`QNet.q_from_rotated_window` crops the
input only, with an 88 px margin, which for such windows is the whole canvas.)

Shapes: heightmap (H, W) cells; canvas P x P px (`canvas_size`); trunk output stride s; rotations R. Inputs as
`QNet.rotate_inputs` takes them (one image); output (R, row1 - row0, col1 - col0) float32.
"""

from __future__ import annotations

import json
from dataclasses import dataclass

import torch
import torch.nn.functional as F  # noqa: N812
from torch import Tensor, nn

from pg_policy.models.nets.lite import LiteTrunk
from pg_policy.models.nets.qnet import QNet, QNetConfig, build_qnet, canvas_size


@dataclass(frozen=True)
class _Stage:
    weight: Tensor  # conv weight with the batch norm folded in
    bias: Tensor
    kernel: int
    stride: int
    padding: int
    dilation: int

    def input_box(self, origin: Tensor, size: int) -> tuple[Tensor, int]:
        """The input box (origins, side) that output cells [origin, origin + size) read."""
        return origin * self.stride - self.padding, self.stride * (size - 1) + self.dilation * (self.kernel - 1) + 1

    def output_size(self, size: int) -> int:
        """Side of this stage's full output for a full input of side `size` (with its padding)."""
        return (size + 2 * self.padding - self.dilation * (self.kernel - 1) - 1) // self.stride + 1


def _fold(seq: nn.Sequential) -> _Stage:
    conv, bn = seq[0], seq[1]
    scale = bn.weight / torch.sqrt(bn.running_var + bn.eps)
    bias = bn.bias - bn.running_mean * scale
    if conv.bias is not None:
        bias = bias + conv.bias * scale
    return _Stage(conv.weight * scale.view(-1, 1, 1, 1), bias, conv.kernel_size[0], conv.stride[0], conv.padding[0],
                  conv.dilation[0])


def supports_windows(net: nn.Module) -> bool:
    """Whether `net` (a QNet, eager or TorchScript) has lite trunks (the only ones `LiteWindowQ` evaluates)."""
    cfg = json.loads(str(getattr(net, "config_json", "{}")))
    return str(cfg.get("backbone", "")).startswith("lite")


class LiteWindowQ:
    """Windowed Q of one lite QNet. Raises ValueError for a net with other trunks. Not thread-safe (no state is
    kept between calls, but torch's thread pool is shared)."""

    def __init__(self, net: nn.Module) -> None:
        eager = build_qnet(QNetConfig.from_dict(json.loads(str(net.config_json))))
        if not isinstance(eager.color_trunk, LiteTrunk):
            raise ValueError(f"windowed Q needs lite trunks, got {type(eager.color_trunk).__name__}")
        state = {k: v for k, v in net.state_dict().items() if k not in ("color_mean", "color_std")}  # constants
        eager.load_state_dict(state)
        self.net: QNet = eager.eval()
        with torch.no_grad():
            self.trunks = [[_fold(s) for s in t.features] for t in (eager.color_trunk, eager.depth_trunk)]
        self.shift = int(eager.color_trunk.shift)
        self.stride = int(eager.color_trunk.stride)

    def q(self, color: Tensor, depth: Tensor, mask: Tensor | None, rotations: list[int],
          window: tuple[int, int, int, int]) -> Tensor:
        """Q (R, rows, cols) of the window (row0, row1, col0, col1) cells for (1, 3, H, W) colour in [0, 1], (1, 1,
        H, W) depth (m) and mask; raises ValueError for a window outside the map or a batch of more than one."""
        h, w = int(depth.shape[2]), int(depth.shape[3])
        r0, r1, c0, c1 = (int(v) for v in window)
        if color.shape[0] != 1 or not (0 <= r0 < r1 <= h and 0 <= c0 < c1 <= w):
            raise ValueError(f"windowed Q takes one image and a window inside the {h} x {w} map, got {window}")
        p = canvas_size(h, w)
        angles = self.net._angles(rotations, color.device)
        stages = self.trunks[0]
        sizes = [p]  # full side of every stage's output
        for st in stages:
            sizes.append(st.output_size(sizes[-1]))
        origin, side = self._head_box(angles, (r0, r1, c0, c1), h, w, p, sizes[-1])
        boxes = [(origin, side)]  # output box of each stage, last stage first
        for st in reversed(stages):
            boxes.append(st.input_box(*boxes[-1]))
        boxes.reverse()  # boxes[0]: the trunk input; boxes[i + 1]: stage i's output
        c, d = self.net._canvases(color, depth, mask)
        feats = []
        for trunk, canvas in zip(self.trunks, (c, d), strict=True):
            x = self._input_crop(canvas, angles, *boxes[0], p)
            for i, st in enumerate(trunk):
                x = F.relu(F.conv2d(x, st.weight, st.bias, st.stride, 0, st.dilation))
                if _crosses_border(*boxes[i + 1], sizes[i + 1]):
                    x = x * _inside(*boxes[i + 1], sizes[i + 1])
            feats.append(x)
        head = self.net.head(torch.cat(feats, 1))
        q = self.net._unrotate(head, angles, h, w, [r0, r1, c0, c1], origin * self.stride, side * self.stride)
        return q

    def _head_box(self, angles: Tensor, window: tuple[int, int, int, int], h: int, w: int, p: int,
                  m: int) -> tuple[Tensor, int]:
        """Per rotation, the origin (row, col) (R, 2) int64 of a square box of head cells (side returned) holding
        every cell the window's bilinear samples read (the full map's border clamp included)."""
        top, left = (p - h) // 2, (p - w) // 2
        rows = torch.tensor([window[0], window[1] - 1], dtype=torch.float64, device=angles.device)
        cols = torch.tensor([window[2], window[3] - 1], dtype=torch.float64, device=angles.device)
        ys = ((2.0 * (rows + top) + 1.0) / p - 1.0).view(1, -1, 1)
        xs = ((2.0 * (cols + left) + 1.0) / p - 1.0).view(1, 1, -1)
        cos, sin = torch.cos(angles).view(-1, 1, 1), torch.sin(angles).view(-1, 1, 1)
        gx = (cos * xs + sin * ys).flatten(1)  # normalised canvas coordinates of the 4 window corners
        gy = (cos * ys - sin * xs).flatten(1)
        lo_hi = []
        for g in (gy, gx):
            cell = ((g + 1.0) * m - 1.0) / 2.0  # head-cell coordinates (align_corners=False)
            lo = torch.floor(cell.min(1).values).clamp(0, m - 1)
            hi = (torch.floor(cell.max(1).values) + 1).clamp(0, m - 1)
            lo_hi.append((lo, hi))
        side = int(max(float((hi - lo).max()) for lo, hi in lo_hi)) + 1
        side = min(side, m)
        origin = torch.stack([torch.minimum(lo, torch.full_like(lo, m - side)) for lo, _ in lo_hi], 1)
        return origin.to(torch.long), side

    def _input_crop(self, canvas: Tensor, angles: Tensor, origin: Tensor, side: int, p: int) -> Tensor:
        """(R, C, side, side): the trunk's input (the rotated canvas shifted by `shift` px, zeros in the shifted-in
        rows and columns) on the box at `origin` (R, 2)."""
        steps = torch.arange(side, device=canvas.device)
        u_y = origin[:, 0:1] + steps  # (R, side) rows of the shifted input
        u_x = origin[:, 1:2] + steps
        ys = ((2.0 * (u_y - self.shift).to(torch.float32) + 1.0) / p - 1.0).unsqueeze(2)  # (R, side, 1)
        xs = ((2.0 * (u_x - self.shift).to(torch.float32) + 1.0) / p - 1.0).unsqueeze(1)  # (R, 1, side)
        cos = torch.cos(angles).to(torch.float32).view(-1, 1, 1)
        sin = torch.sin(angles).to(torch.float32).view(-1, 1, 1)
        grid = torch.stack([cos * xs - sin * ys, sin * xs + cos * ys], -1)
        x = F.grid_sample(canvas.expand(angles.shape[0], -1, -1, -1), grid, mode="bilinear", padding_mode="border",
                          align_corners=False)
        if bool((origin >= self.shift).all()):
            return x
        keep = ((u_y >= self.shift).view(-1, 1, side, 1) & (u_x >= self.shift).view(-1, 1, 1, side))
        return x * keep.to(x.dtype)


def _crosses_border(origin: Tensor, side: int, full: int) -> bool:
    """Whether some rotation's box reaches outside the full feature map [0, full)^2."""
    return bool((origin < 0).any() or (origin + side > full).any())


def _inside(origin: Tensor, side: int, full: int) -> Tensor:
    """(R, 1, side, side) float mask: 1 where a box's cell lies inside the full feature map [0, full)^2."""
    steps = torch.arange(side, device=origin.device)
    rows = origin[:, 0:1] + steps
    cols = origin[:, 1:2] + steps
    ok = ((rows >= 0) & (rows < full)).view(-1, 1, side, 1) & ((cols >= 0) & (cols < full)).view(-1, 1, 1, side)
    return ok.to(torch.float32)

