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
from collections.abc import Sequence
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


@dataclass(frozen=True)
class _Plan:
    """What one net computes for one window: yaw per rotation (R,) float64, map H x W, canvas side P px, the window,
    the full side of every stage's output and the box (origins (R, 2) int64, side) of the trunk input (boxes[0])
    and of every stage's output."""

    angles: Tensor
    h: int
    w: int
    p: int
    window: tuple[int, int, int, int]
    sizes: list[int]
    boxes: list[tuple[Tensor, int]]


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
        device = next(iter(net.parameters()), torch.empty(0)).device  # the evaluator lives where `net` does
        self.net: QNet = eager.to(device).eval()
        with torch.no_grad():
            self.trunks = [[_fold(s) for s in t.features] for t in (eager.color_trunk, eager.depth_trunk)]
        self.shift = int(eager.color_trunk.shift)
        self.stride = int(eager.color_trunk.stride)
        stem = self.trunks[0][0]
        if stem.kernel != stem.stride or stem.padding != 0 or stem.dilation != 1:
            raise ValueError("windowed Q needs a patchify stem (kernel = stride, no padding)")
        self.patch = stem.stride  # the stem's k: it reads k x k patches of the input

    def q(self, color: Tensor, depth: Tensor, mask: Tensor | None, rotations: list[int],
          window: tuple[int, int, int, int]) -> Tensor:
        """Q (R, rows, cols) of the window (row0, row1, col0, col1) cells for (1, 3, H, W) colour in [0, 1], (1, 1,
        H, W) depth (m) and mask; raises ValueError for a window outside the map or a batch of more than one."""
        return windowed_q([self], color, depth, mask, rotations, [window])[0]

    def plan(self, h: int, w: int, rotations: list[int], window: tuple[int, int, int, int],
             device: torch.device) -> _Plan:
        """The boxes every stage computes for the window cells of an H x W map. Raises ValueError for a window
        outside the map."""
        r0, r1, c0, c1 = (int(v) for v in window)
        if not (0 <= r0 < r1 <= h and 0 <= c0 < c1 <= w):
            raise ValueError(f"windowed Q takes a window inside the {h} x {w} map, got {window}")
        p = canvas_size(h, w)
        angles = self.net._angles(rotations, device)
        sizes = [p]  # full side of every stage's output
        for st in self.trunks[0]:
            sizes.append(st.output_size(sizes[-1]))
        origin, side = self._head_box(angles, (r0, r1, c0, c1), h, w, p, sizes[-1])
        boxes = [(origin, side)]  # output box of each stage, last stage first
        for st in reversed(self.trunks[0]):
            boxes.append(st.input_box(*boxes[-1]))
        boxes.reverse()  # boxes[0]: the trunk input; boxes[i + 1]: stage i's output
        return _Plan(angles, h, w, p, (r0, r1, c0, c1), sizes, boxes)

    def canvas(self, color: Tensor, depth: Tensor, mask: Tensor | None) -> Tensor:
        """(1, 6, P, P): the colour trunk's canvas (channels 0-2) and the depth trunk's (3-5), normalised."""
        return torch.cat(self.net._canvases(color, depth, mask), 1)

    def stem(self, patches: Tensor, m: int) -> list[Tensor]:
        """(R, 6 k^2, m^2) patch-ordered trunk inputs (`_patches`) -> the first stage's output of each trunk, (R, C0,
        m, m): the k x k / k stem convolution as one matrix product per trunk (channel c, patch offset (dy, dx) at
        row c k^2 + dy k + dx, as the weight's layout)."""
        out = []
        half = patches.shape[1] // 2
        for trunk, x in zip(self.trunks, (patches[:, :half], patches[:, half:]), strict=True):
            st = trunk[0]
            y = torch.matmul(st.weight.reshape(st.weight.shape[0], -1), x) + st.bias.view(1, -1, 1)
            out.append(F.relu(y).view(x.shape[0], -1, m, m))
        return out

    def q_from_stem(self, stems: list[Tensor], plan: _Plan) -> Tensor:
        """The stem outputs of both trunks on `plan`'s stage-0 box -> Q (R, rows, cols) of its window."""
        feats = []
        for trunk, x in zip(self.trunks, stems, strict=True):
            for i, st in enumerate(trunk):
                if i > 0:
                    x = F.relu(F.conv2d(x, st.weight, st.bias, st.stride, 0, st.dilation))
                if _crosses_border(*plan.boxes[i + 1], plan.sizes[i + 1]):
                    x = x * _inside(*plan.boxes[i + 1], plan.sizes[i + 1])
            feats.append(x)
        head = self.net.head(torch.cat(feats, 1))
        origin, side = plan.boxes[-1]
        return self.net._unrotate(head, plan.angles, plan.h, plan.w, list(plan.window), origin * self.stride,
                                  side * self.stride)

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

    def _patches(self, canvas: Tensor, angles: Tensor, origin: Tensor, side: int, p: int) -> Tensor:
        """(R, C k^2, m^2), m = side / k: the trunk input (the rotated canvas shifted by `shift` px, zeros in the
        shifted-in rows and columns) on the box at `origin` (R, 2) (multiples of k), sampled straight into the
        stem's patch order: channel c, offset (dy, dx) inside patch (i, j) at [c k^2 + dy k + dx, i m + j]. Every
        pixel is sampled at the same point as in the (R, C, side, side) image, only stored elsewhere."""
        k, r = self.patch, angles.shape[0]
        m = side // k
        grid_steps = torch.arange(m, device=canvas.device).view(1, 1, m) * k + torch.arange(
            k, device=canvas.device).view(1, k, 1)
        u_y = origin[:, 0].view(-1, 1, 1) + grid_steps  # (R, k, m): input row of offset dy in patch row i
        u_x = origin[:, 1].view(-1, 1, 1) + grid_steps
        ys = ((2.0 * (u_y - self.shift).to(torch.float32) + 1.0) / p - 1.0).view(r, k, 1, m, 1)
        xs = ((2.0 * (u_x - self.shift).to(torch.float32) + 1.0) / p - 1.0).view(r, 1, k, 1, m)
        cos = torch.cos(angles).to(torch.float32).view(-1, 1, 1, 1, 1)
        sin = torch.sin(angles).to(torch.float32).view(-1, 1, 1, 1, 1)
        grid = torch.stack(torch.broadcast_tensors(cos * xs - sin * ys, sin * xs + cos * ys), -1)
        x = F.grid_sample(canvas.expand(r, -1, -1, -1), grid.reshape(r, k * k, m * m, 2), mode="bilinear",
                          padding_mode="border", align_corners=False)  # (R, C, k^2, m^2)
        if not bool((origin >= self.shift).all()):
            keep = (u_y >= self.shift).view(r, 1, k, 1, m, 1) & (u_x >= self.shift).view(r, 1, 1, k, 1, m)
            x = x * keep.reshape(r, 1, k * k, m * m).to(x.dtype)
        return x.reshape(r, -1, m * m)


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



def windowed_q(nets: Sequence[LiteWindowQ], color: Tensor, depth: Tensor, mask: Tensor | None, rotations: list[int],
               windows: Sequence[tuple[int, int, int, int]]) -> list[Tensor]:
    """Q (R, rows, cols) of windows[i] for nets[i] (each as `LiteWindowQ.q`), sharing the input sampling: nets whose
    canvases agree (same goal input and input shift) sample their rotated canvases once, colour and depth together,
    on the union of their input boxes, straight into the stem's patch order; each net applies its stem there (a
    matrix product, cheap) and reads its own box of stem cells out of it. Every sampled pixel depends on its
    position only, so the values are those of separate calls. Raises ValueError as `LiteWindowQ.q`."""
    if len(nets) != len(windows):
        raise ValueError(f"windowed Q: {len(nets)} nets but {len(windows)} windows")
    if color.shape[0] != 1:
        raise ValueError(f"windowed Q takes one image, got a batch of {color.shape[0]}")
    h, w = int(depth.shape[2]), int(depth.shape[3])
    plans = [net.plan(h, w, rotations, win, color.device) for net, win in zip(nets, windows, strict=True)]
    out: list[Tensor | None] = [None] * len(nets)
    groups: dict[tuple[bool, int], list[int]] = {}
    for i, net in enumerate(nets):
        groups.setdefault((bool(net.net.use_mask), net.shift), []).append(i)
    for members in groups.values():
        first = nets[members[0]]
        canvas = first.canvas(color, depth, mask)
        lo = torch.stack([plans[i].boxes[0][0] for i in members]).amin(0)  # (R, 2)
        hi = torch.stack([plans[i].boxes[0][0] + plans[i].boxes[0][1] for i in members]).amax(0)
        side = int((hi - lo).max())
        k = first.patch
        patches = first._patches(canvas, plans[members[0]].angles, lo, side, plans[members[0]].p)
        for i in members:
            origin, s = plans[i].boxes[0]
            off = torch.div(origin - lo, k, rounding_mode="floor").tolist()  # stem cells
            stems = nets[i].stem(patches, side // k)
            if s != side or any(any(o) for o in off):
                m = s // k
                stems = [torch.stack([f[r, :, a:a + m, b:b + m] for r, (a, b) in enumerate(off)]) for f in stems]
            out[i] = nets[i].q_from_stem(stems, plans[i])
    return [q for q in out if q is not None]
