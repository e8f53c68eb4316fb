"""The click-conditioned object segmenter: a small U-Net that maps a heightmap window and a clicked cell to the
mask of the object under the click.

Input (B, IN_CHANNELS, S, S) float32, S a multiple of 32 (the window, `encode_window`): colour RGB / 255 (3),
height / HEIGHT_SCALE_M (1), valid (1, 0 or 1), the click as a Gaussian of CLICK_SIGMA_CELLS cells at its cell (1).
Output (B, 1, S, S) float32 logits: > 0 where the cell belongs to the clicked object. GroupNorm (no batch
statistics): a batch of one gives what it gives in a batch. ~0.1 M parameters.
"""

from __future__ import annotations

import numpy as np
import torch
from torch import nn

IN_CHANNELS = 6
HEIGHT_SCALE_M = 0.1  # heights are divided by this (m)
CLICK_SIGMA_CELLS = 3.0  # the click channel's Gaussian (cells)
WIDTHS = (12, 24, 48, 64, 64, 64)  # channels per level (five 2x downsamplings: the 128-cell window sees itself whole)


def _block(cin: int, cout: int) -> nn.Sequential:
    return nn.Sequential(nn.Conv2d(cin, cout, 3, padding=1, bias=False), nn.GroupNorm(4, cout), nn.ReLU(inplace=True),
                         nn.Conv2d(cout, cout, 3, padding=1, bias=False), nn.GroupNorm(4, cout), nn.ReLU(inplace=True))


class _Up(nn.Module):
    """One decoder level: 2x transposed-conv upsampling, the encoder's skip concatenated, a conv block."""

    def __init__(self, cin: int, cout: int) -> None:
        super().__init__()
        self.up = nn.ConvTranspose2d(cin, cout, 2, stride=2)
        self.block = _block(2 * cout, cout)

    def forward(self, x: torch.Tensor, skip: torch.Tensor) -> torch.Tensor:
        return self.block(torch.cat([self.up(x), skip], dim=1))


class ClickSegmenter(nn.Module):
    """U-Net over the window (module docstring): encoder WIDTHS, decoder with skip connections, 1x1 head."""

    def __init__(self) -> None:
        super().__init__()
        w = WIDTHS
        self.enc = nn.ModuleList([_block(IN_CHANNELS, w[0])] + [_block(w[k - 1], w[k]) for k in range(1, len(w))])
        self.dec = nn.ModuleList([_Up(w[k], w[k - 1]) for k in range(len(w) - 1, 0, -1)])
        self.head = nn.Conv2d(w[0], 1, 1)
        self.pool = nn.MaxPool2d(2)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        skips: list[torch.Tensor] = []
        for k, enc in enumerate(self.enc):
            x = enc(x if k == 0 else self.pool(x))
            skips.append(x)
        x = skips.pop()
        for dec in self.dec:
            x = dec(x, skips.pop())
        return self.head(x)


def encode_window(color: np.ndarray, height: np.ndarray, valid: np.ndarray, row: int, col: int,
                  size: int) -> np.ndarray:
    """(IN_CHANNELS, size, size) float32 input of the window of `size` cells centred on (row, col), cells off the
    grid zero. color (H, W, 3) uint8, height (H, W) m, valid (H, W) bool; (row, col) the clicked cell."""
    h, w = height.shape
    half = size // 2
    out = np.zeros((IN_CHANNELS, size, size), np.float32)
    r0, c0 = row - half, col - half
    rs, re = max(r0, 0), min(r0 + size, h)
    cs, ce = max(c0, 0), min(c0 + size, w)
    dst = (slice(rs - r0, re - r0), slice(cs - c0, ce - c0))
    out[0:3][(slice(None), *dst)] = np.moveaxis(color[rs:re, cs:ce], -1, 0) / 255.0
    out[3][dst] = height[rs:re, cs:ce] / HEIGHT_SCALE_M
    out[4][dst] = valid[rs:re, cs:ce]
    yy, xx = np.mgrid[0:size, 0:size]
    out[5] = np.exp(-((yy - half) ** 2 + (xx - half) ** 2) / (2 * CLICK_SIGMA_CELLS**2))
    return out


def paste_window(window: np.ndarray, shape: tuple[int, int], row: int, col: int) -> np.ndarray:
    """The (size, size) array `window` centred on (row, col) placed into a zero array of `shape` (the inverse of
    encode_window's crop; cells off the grid dropped)."""
    size = window.shape[0]
    half = size // 2
    out = np.zeros(shape, window.dtype)
    r0, c0 = row - half, col - half
    rs, re = max(r0, 0), min(r0 + size, shape[0])
    cs, ce = max(c0, 0), min(c0 + size, shape[1])
    out[rs:re, cs:ce] = window[rs - r0:re - r0, cs - c0:ce - c0]
    return out
