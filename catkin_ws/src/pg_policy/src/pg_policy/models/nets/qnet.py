"""The paper's push or grasp Q network (DESIGN.md section 7) with all heightmap rotations batched in one pass.

Inputs (one convention everywhere, also for exported TorchScript files):
- color: (B, 3, H, W) float32 RGB in [0, 1] (heightmap colour / 255), rows = world y, cols = world x (VPG/ravens).
- depth: (B, 1, H, W) float32 heightmap heights in metres above the workspace zmin.
- mask:  (B, 1, H, W) float32 goal mask in {0, 1}; required when goal == "mask", ignored (may be None) otherwise.
Output: Q (B, R, H, W) float32, R = len(rotations) (default: all `rotations` of the config, in index order).

Normalisation lives inside the module: colour (c - ImageNet mean) / ImageNet std; depth (d - 0.01 m) / 0.03 m (VPG);
mask (m - 0.5) / 0.5. The colour trunk sees the normalised RGB, the depth trunk sees (d, d, d), or (d, d, m) when
goal == "mask", so ImageNet DenseNet weights fit both. Features are concatenated and fed to the head
BN-ReLU-conv1x1(64)-BN-ReLU-conv1x1(1).

Rotation convention (VPG's): rotation index r means yaw theta = r * 360 / R degrees, counter-clockwise about world +z
(from +x towards +y). With heightmap vectors written (col, row) = (x, y) / resolution, the net sees the rotated map
    I_r(p) = I(c + Rot(theta) (p - c))        (c = canvas centre, Rot(theta) = [[cos, -sin], [sin, cos]])
so the world direction (cos theta, sin theta) appears along +col of the rotated map: a net that learns its primitive
along +col (push direction; for grasps the jaw closing axis) gives at Q[:, k, row, col] the value of the primitive at
the cell (row, col) with gripper yaw = rotations[k] * 360 / R degrees in `world`. For r = R/4 (90 deg) the rotated map
is ``np.rot90(I, 1)`` and Q = ``np.rot90(Q_0(np.rot90(I, 1)), -1)`` (up to float rounding, ~1e-5).
Mechanics: inputs are zero-padded (raw values: black, height 0, mask 0; done as padding the normalised values with
the normalised 0) to a square canvas of side P = ceil(sqrt(H^2 + W^2)) rounded up to a multiple of 32 (224 -> 320)
so no corner is lost, rotated by grid_sample (bilinear) on the grid F.affine_grid gives for
theta = [[cos, -sin, 0], [sin, cos, 0]] (align_corners=False), for all B * R (image, rotation) pairs in ONE backbone
batch, then
the head's (B * R, 1, P/s, P/s) output is bilinearly upsampled AND rotated back in one grid_sample evaluated at the
H x W original cells only (bilinear upsampling followed by evaluation at the exact rotated-back location; at r = 0 this
equals F.interpolate(size=P, bilinear, align_corners=False) cropped to the heightmap).

Exported methods (kept by torch.jit.script, used by `pg_policy.models.inference`): `rotate_inputs` / `q_from_rotated`
split
forward so two nets share one rotation of the inputs; `rotate_inputs_window` / `q_from_rotated_window` compute only a
window of cells from stride-aligned crops of the rotated canvases (equal to the full map for a context margin >=
`exact_margin` px, attribute: 88 for lite, -1 = never exact for DenseNet-121); `forward_indexed` gives one rotation
per image (training). Attributes: num_rotations, use_mask, exact_margin, config_json (the QNetConfig as JSON).

Scriptable with torch.jit.script (also trace-able for a fixed shape and rotation list). Eager calls raise ValueError for
bad shapes, a missing goal mask, an out-of-range rotation or window; scripted modules raise torch.jit.Error with the
same text.
"""

from __future__ import annotations

import json
import math
from collections import OrderedDict
from dataclasses import asdict, dataclass
from typing import Any

import torch
import torch.nn.functional as F
from torch import Tensor, nn

from pg_policy.models.nets.registry import get_backbone

CANVAS_MULTIPLE = 32
COLOR_MEAN = (0.485, 0.456, 0.406)
COLOR_STD = (0.229, 0.224, 0.225)
DEPTH_MEAN = 0.01  # m
DEPTH_STD = 0.03  # m
MASK_MEAN = 0.5
MASK_STD = 0.5
GOALS = ("none", "mask")
HEAD_CHANNELS = 64


@dataclass(frozen=True)
class QNetConfig:
    """backbone: a key of BACKBONES; goal: "none" (mask applied to the Q maps only) or "mask" (also an input);
    rotations: number of heightmap rotations R; pretrained: torchvision densenet121 .pth for both trunks, or None."""

    backbone: str = "lite"
    goal: str = "none"
    rotations: int = 16
    pretrained: str | None = None

    def __post_init__(self) -> None:
        get_backbone(self.backbone)
        if self.goal not in GOALS:
            raise ValueError(f"goal must be one of {GOALS}, got {self.goal!r}")
        if int(self.rotations) < 1:
            raise ValueError(f"rotations must be >= 1, got {self.rotations}")

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> QNetConfig:
        """Build from a mapping holding (a subset of) the fields; unknown keys raise ValueError."""
        unknown = set(d) - set(cls.__dataclass_fields__)
        if unknown:
            raise ValueError(f"unknown QNetConfig fields: {sorted(unknown)}")
        return cls(**d)


def canvas_size(height: int, width: int, multiple: int = 32) -> int:
    """Side P (px) of the padded square canvas: ceil(sqrt(H^2 + W^2)) rounded up to a multiple of 32."""
    diag = int(math.ceil(math.sqrt(float(height * height + width * width))))
    return ((diag + multiple - 1) // multiple) * multiple


class QNet(nn.Module):
    """Two trunks (colour, depth) + head; see the module docstring for the inputs, outputs and rotation convention."""

    def __init__(self, config: QNetConfig) -> None:
        super().__init__()
        backbone = get_backbone(config.backbone)
        self.color_trunk = backbone.build()
        self.depth_trunk = backbone.build()
        if config.pretrained:
            backbone.load_pretrained(self.color_trunk, config.pretrained)
            backbone.load_pretrained(self.depth_trunk, config.pretrained)
        stride = int(self.color_trunk.stride)
        if CANVAS_MULTIPLE % stride:
            raise ValueError(f"backbone stride {stride} must divide {CANVAS_MULTIPLE}")
        ch = int(self.color_trunk.out_channels) + int(self.depth_trunk.out_channels)
        self.head = nn.Sequential(OrderedDict(
            norm0=nn.BatchNorm2d(ch), relu0=nn.ReLU(inplace=True),
            conv0=nn.Conv2d(ch, HEAD_CHANNELS, kernel_size=1, bias=False),
            norm1=nn.BatchNorm2d(HEAD_CHANNELS), relu1=nn.ReLU(inplace=True),
            conv1=nn.Conv2d(HEAD_CHANNELS, 1, kernel_size=1, bias=False),
        ))
        for m in self.head.modules():
            if isinstance(m, nn.Conv2d):
                nn.init.kaiming_normal_(m.weight)
            elif isinstance(m, nn.BatchNorm2d):
                nn.init.constant_(m.weight, 1.0)
                nn.init.constant_(m.bias, 0.0)
        self.register_buffer("color_mean", torch.tensor(COLOR_MEAN).view(1, 3, 1, 1), persistent=False)
        self.register_buffer("color_std", torch.tensor(COLOR_STD).view(1, 3, 1, 1), persistent=False)
        self.depth_mean, self.depth_std = float(DEPTH_MEAN), float(DEPTH_STD)
        self.mask_mean, self.mask_std = float(MASK_MEAN), float(MASK_STD)
        self.num_rotations: int = int(config.rotations)
        self.exact_margin: int = int(getattr(self.color_trunk, "exact_margin", -1))
        self.use_mask: bool = config.goal == "mask"
        self.config_json: str = json.dumps(config.to_dict(), sort_keys=True)

    # -- public (all exported to TorchScript) -----------------------------------------------------------------------
    def forward(self, color: Tensor, depth: Tensor, mask: Tensor | None = None,
                rotations: list[int] | None = None) -> Tensor:
        """(B,3,H,W) [0,1], (B,1,H,W) m, (B,1,H,W) {0,1} or None, rotation indices -> Q (B, R, H, W) float32."""
        rots = self._rotation_list(rotations)
        color_rot, depth_rot = self.rotate_inputs(color, depth, mask, rots)
        return self.q_from_rotated(color_rot, depth_rot, rots, color.shape[2], color.shape[3])

    @torch.jit.export
    def rotate_inputs(self, color: Tensor, depth: Tensor, mask: Tensor | None = None,
                      rotations: list[int] | None = None) -> tuple[Tensor, Tensor]:
        """Raw inputs -> the two trunks' inputs: (B * R, 3, P, P) float32 each, normalised, image-major order.

        Weight-free: the canvases of one QNet feed `q_from_rotated` of any QNet with the same `use_mask`.
        """
        rots = self._rotation_list(rotations)
        b = color.shape[0]
        angles = self._angles(rots, color.device).repeat(b)
        src = torch.arange(b, device=color.device).repeat_interleave(len(rots))
        c, d = self._canvases(color, depth, mask)
        grid = self._rotation_grid(angles, c.shape[2], self._zero_origins(angles), c.shape[2])
        return self._sample(c, src, grid), self._sample(d, src, grid)

    @torch.jit.export
    def q_from_rotated(self, color_rot: Tensor, depth_rot: Tensor, rotations: list[int] | None, height: int,
                       width: int) -> Tensor:
        """Canvases from `rotate_inputs` (same rotations) -> Q (B, R, height, width) float32 in the original frame."""
        rots = self._rotation_list(rotations)
        r = len(rots)
        n = color_rot.shape[0]
        if n % r != 0 or color_rot.shape != depth_rot.shape or color_rot.shape[2] != canvas_size(height, width):
            raise ValueError("q_from_rotated: canvases must be (B * R, 3, P, P) from rotate_inputs, same rotations")
        angles = self._angles(rots, color_rot.device).repeat(n // r)
        p = color_rot.shape[2]
        q = self._unrotate(self._q_low(color_rot, depth_rot), angles, height, width, [0, height, 0, width],
                           self._zero_origins(angles), p)
        return q.view(n // r, r, height, width)

    @torch.jit.export
    def forward_indexed(self, color: Tensor, depth: Tensor, mask: Tensor | None, rotation: Tensor) -> Tensor:
        """One rotation per image (training): rotation (B,) int64 indices -> Q (B, H, W) float32."""
        if rotation.dim() != 1 or rotation.shape[0] != color.shape[0]:
            raise ValueError("forward_indexed: rotation must be (B,) with one index per image")
        if bool((rotation < 0).any()) or bool((rotation >= self.num_rotations).any()):
            raise ValueError("forward_indexed: rotation index out of range")
        angles = rotation.to(torch.float64) * (2.0 * math.pi / self.num_rotations)
        src = torch.arange(color.shape[0], device=color.device)
        c, d = self._canvases(color, depth, mask)
        p = c.shape[2]
        zero = self._zero_origins(angles)
        grid = self._rotation_grid(angles, p, zero, p)
        q_low = self._q_low(self._sample(c, src, grid), self._sample(d, src, grid))
        h, w = color.shape[2], color.shape[3]
        return self._unrotate(q_low, angles, h, w, [0, h, 0, w], zero, p)

    @torch.jit.export
    def rotate_inputs_window(self, color: Tensor, depth: Tensor, mask: Tensor | None, rotations: list[int] | None,
                             window: list[int], margin: int) -> tuple[Tensor, Tensor, Tensor]:
        """Like `rotate_inputs`, but only a square crop of each rotated canvas: the crop covers the rotated `window`
        (row0, row1, col0, col1 of the heightmap) grown by `margin` px, with corners on multiples of 32 px of the
        canvas (so every trunk's stride grid is that of the full canvas). Returns (colour crops, depth crops) of
        (B * R, 3, S, S) float32 and origins (R, 2) int64 (row, col of each crop in its canvas)."""
        rots = self._rotation_list(rotations)
        b, h, w = color.shape[0], color.shape[2], color.shape[3]
        angles = self._angles(rots, color.device)
        origins, side = self._crop_origins(angles, window, margin, h, w)
        c, d = self._canvases(color, depth, mask)
        grid = self._rotation_grid(angles, c.shape[2], origins, side).repeat(b, 1, 1, 1)
        src = torch.arange(b, device=color.device).repeat_interleave(len(rots))
        return self._sample(c, src, grid), self._sample(d, src, grid), origins

    @torch.jit.export
    def q_from_rotated_window(self, color_rot: Tensor, depth_rot: Tensor, origins: Tensor,
                              rotations: list[int] | None, height: int, width: int, window: list[int]) -> Tensor:
        """Crops from `rotate_inputs_window` -> Q (B, R, row1 - row0, col1 - col0) float32 of the window cells.

        Equal to the full map's window (up to float rounding) wherever the trunk's receptive field plus one output
        cell fits in the crop, i.e. for margin >= `exact_margin` (when that is >= 0); approximate otherwise."""
        rots = self._rotation_list(rotations)
        r = len(rots)
        n = color_rot.shape[0]
        if n % r != 0 or color_rot.shape != depth_rot.shape or origins.shape[0] != r:
            raise ValueError("q_from_rotated_window: crops must come from rotate_inputs_window, same rotations")
        angles = self._angles(rots, color_rot.device)
        q = self._unrotate(self._q_low(color_rot, depth_rot), angles.repeat(n // r), height, width, window,
                           origins.repeat(n // r, 1), color_rot.shape[2])
        return q.view(n // r, r, window[1] - window[0], window[3] - window[2])

    # -- internals ------------------------------------------------------------------------------------------------
    def _rotation_list(self, rotations: list[int] | None) -> list[int]:
        if rotations is None:
            return list(range(self.num_rotations))
        if len(rotations) == 0:
            raise ValueError("rotations must not be empty")
        for r in rotations:
            if r < 0 or r >= self.num_rotations:
                raise ValueError("rotation index out of range [0, num_rotations)")
        return rotations

    def _angles(self, rots: list[int], device: torch.device) -> Tensor:
        """(R,) float64 yaw (rad) of each rotation index."""
        return torch.tensor(rots, dtype=torch.float64, device=device) * (2.0 * math.pi / self.num_rotations)

    def _canvases(self, color: Tensor, depth: Tensor, mask: Tensor | None) -> tuple[Tensor, Tensor]:
        """Normalised, zero-padded (B, 3, P, P) float32 trunk inputs: colour and (d, d, d) or (d, d, m).

        Padding a raw 0 (black, height 0, mask 0) is padding its normalised value: pad(x / std) - mean / std.
        """
        if color.dim() != 4 or color.shape[1] != 3:
            raise ValueError("color must be (B, 3, H, W) float in [0, 1]")
        b, h, w = color.shape[0], color.shape[2], color.shape[3]
        if depth.dim() != 4 or depth.shape[0] != b or depth.shape[1] != 1 or depth.shape[2] != h or depth.shape[3] != w:
            raise ValueError("depth must be (B, 1, H, W) metres, matching color")
        p = canvas_size(h, w)
        top, left = (p - h) // 2, (p - w) // 2
        pad = [left, p - w - left, top, p - h - top]
        c = F.pad(color.to(torch.float32) / self.color_std, pad) - self.color_mean / self.color_std
        d = F.pad(depth.to(torch.float32) / self.depth_std, pad) - self.depth_mean / self.depth_std
        if self.use_mask:
            if mask is None:
                raise ValueError("this net takes the goal mask as input (goal == 'mask'): mask is required")
            if mask.shape != depth.shape:
                raise ValueError("mask must be (B, 1, H, W) like depth")
            third = F.pad(mask.to(torch.float32) / self.mask_std, pad) - self.mask_mean / self.mask_std
        else:
            third = d
        return c, torch.cat([d, d, third], 1)

    def _zero_origins(self, angles: Tensor) -> Tensor:
        return torch.zeros(angles.shape[0], 2, dtype=torch.long, device=angles.device)

    def _rotation_grid(self, angles: Tensor, p: int, origins: Tensor, side: int) -> Tensor:
        """(N, S, S, 2) grid: output point q of crop i (canvas rows/cols origins[i] + [0, S)) samples the canvas
        at c + Rot(angles[i]) (q - c); with zero origins and S = P the whole rotated canvas."""
        base = (2.0 * torch.arange(p, dtype=torch.float32, device=angles.device) + 1.0) / p - 1.0
        steps = torch.arange(side, device=angles.device)
        ys = base[origins[:, 0:1] + steps].unsqueeze(2)  # (N, S, 1)
        xs = base[origins[:, 1:2] + steps].unsqueeze(1)  # (N, 1, S)
        cos = torch.cos(angles).to(torch.float32).view(-1, 1, 1)
        sin = torch.sin(angles).to(torch.float32).view(-1, 1, 1)
        return torch.stack([cos * xs - sin * ys, sin * xs + cos * ys], -1)

    def _crop_origins(self, angles: Tensor, window: list[int], margin: int, h: int, w: int) -> tuple[Tensor, int]:
        """(R, 2) int64 crop origins (row, col; multiples of 32) and the common side S (multiple of 32, <= P)."""
        if len(window) != 4 or not (0 <= window[0] < window[1] <= h and 0 <= window[2] < window[3] <= w):
            raise ValueError("window must be [row0, row1, col0, col1] inside the heightmap, row0 < row1, col0 < col1")
        if margin < 0:
            raise ValueError("margin must be >= 0 px")
        p = canvas_size(h, w)
        top, left = (p - h) // 2, (p - w) // 2
        half = p / 2.0
        cy = torch.tensor([window[0], window[0], window[1], window[1]], dtype=torch.float64) + top - half
        cx = torch.tensor([window[2], window[3], window[2], window[3]], dtype=torch.float64) + left - half
        cos = torch.cos(angles).view(-1, 1).cpu()
        sin = torch.sin(angles).view(-1, 1).cpu()
        ry = cos * cy - sin * cx + half  # rotated-frame corners, canvas px (R, 4)
        rx = cos * cx + sin * cy + half
        lo = torch.stack([ry.min(1)[0], rx.min(1)[0]], 1) - margin
        hi = torch.stack([ry.max(1)[0], rx.max(1)[0]], 1) + margin
        lo = (torch.floor(lo / 32.0) * 32.0).clamp(0.0, float(p))
        hi = (torch.ceil(hi / 32.0) * 32.0).clamp(0.0, float(p))
        side = int((hi - lo).max().item())
        origins = torch.minimum(lo, torch.full_like(lo, float(p - side))).to(torch.long)
        return origins.to(angles.device), side

    def _sample(self, x: Tensor, src: Tensor, grid: Tensor) -> Tensor:
        """(B, C, P, P) canvases -> (N, C, P, P): canvas src[i] sampled on grid[i] (bilinear, border = padding)."""
        x = x.expand(src.shape[0], -1, -1, -1) if x.shape[0] == 1 else x.index_select(0, src)
        return F.grid_sample(x, grid, mode="bilinear", padding_mode="border", align_corners=False)

    def _q_low(self, color_rot: Tensor, depth_rot: Tensor) -> Tensor:
        """(N, 3, P, P) x 2 normalised canvases -> (N, 1, P/s, P/s) head output."""
        return self.head(torch.cat([self.color_trunk(color_rot), self.depth_trunk(depth_rot)], 1))

    def _unrotate(self, q: Tensor, angles: Tensor, h: int, w: int, window: list[int], origins: Tensor,
                  side: int) -> Tensor:
        """(N, 1, S/s, S/s) head output of canvas crops (origins (N, 2), side S; the whole canvas: zero origins,
        S = P) -> (N, rows, cols) Q of the heightmap `window` cells: bilinear upsampling and inverse rotation in one
        grid_sample evaluated at those cells only."""
        p = canvas_size(h, w)
        top, left = (p - h) // 2, (p - w) // 2
        rows = torch.arange(window[0], window[1], dtype=torch.float64, device=q.device)
        cols = torch.arange(window[2], window[3], dtype=torch.float64, device=q.device)
        ys = ((2.0 * (rows + top) + 1.0) / p - 1.0).view(1, -1, 1)
        xs = ((2.0 * (cols + left) + 1.0) / p - 1.0).view(1, 1, -1)
        cos, sin = torch.cos(angles).view(-1, 1, 1), torch.sin(angles).view(-1, 1, 1)
        o = origins.to(torch.float64)
        gx = (cos * xs + sin * ys + 1.0) * (p / side) - 1.0 - 2.0 * o[:, 1].view(-1, 1, 1) / side
        gy = (cos * ys - sin * xs + 1.0) * (p / side) - 1.0 - 2.0 * o[:, 0].view(-1, 1, 1) / side
        grid = torch.stack([gx, gy], -1).to(q.dtype)
        return F.grid_sample(q, grid, mode="bilinear", padding_mode="border", align_corners=False)[:, 0]


def build_qnet(config: QNetConfig, seed: int | None = None) -> QNet:
    """A fresh QNet in eval mode; `seed` makes the random initialisation reproducible (torch's global RNG)."""
    if seed is not None:
        torch.manual_seed(seed)
    return QNet(config).eval()
