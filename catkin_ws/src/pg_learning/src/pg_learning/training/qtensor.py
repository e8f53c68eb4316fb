"""Glue between numpy heightmaps and the Q networks during training: tensors in, Q maps out.

Conventions: heightmap colour (H, W, 3) uint8 -> (1, 3, H, W) float in [0, 1]; heights (H, W) m -> (1, 1, H, W);
goal mask (H, W) bool -> (1, 1, H, W) float. Q maps come back as numpy (R, H, W) float32.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import torch

from pg_core.geometry import Geometry
from pg_core.heightmap import Heightmap
from pg_core.palette import COLORS
from pg_policy.decision.decision import action_pose as _action_pose
from pg_policy.decision.decision import masked_argmax as _masked_argmax
from pg_policy.decision.decision import masked_max as _masked_max
from pg_policy.decision.decision import push_region as _push_region
from pg_policy.models.nets.qnet import QNet, QNetConfig, build_qnet

COLOR_HEIGHT_M = 0.005  # color_at: cells lower than this show the table, not an object's colour


def build(cfg: Any, role: str) -> QNet:
    """A fresh net of the run's variant (cfg.backbone, cfg.goal, cfg.rotations, cfg.pretrained)."""
    pre = str(cfg.pretrained) if getattr(cfg, "pretrained", None) else None
    seed = int(cfg.seed) * 2 + (0 if role == "grasp" else 1)
    return build_qnet(QNetConfig(backbone=cfg.backbone, goal=cfg.goal, rotations=cfg.rotations, pretrained=pre),
                      seed=seed)


def tensors(color: np.ndarray, height: np.ndarray, mask: np.ndarray,
            device: str | torch.device = "cpu") -> tuple[torch.Tensor, ...]:
    """One observation ((H, W, 3), (H, W), (H, W)) or a batch ((N, H, W, 3), (N, H, W), (N, H, W)) -> net inputs
    (N, 3, H, W) in [0, 1], (N, 1, H, W) m, (N, 1, H, W) {0, 1}, float32 on `device` (N = 1 for one)."""
    if np.ndim(height) == 2:
        color, height, mask = color[None], np.asarray(height)[None], np.asarray(mask)[None]
    c = torch.from_numpy(np.ascontiguousarray(color)).to(device).permute(0, 3, 1, 2).float().div_(255.0)
    d = torch.from_numpy(np.ascontiguousarray(height, dtype=np.float32)).to(device).unsqueeze(1)
    m = torch.from_numpy(np.ascontiguousarray(mask, dtype=np.float32)).to(device).unsqueeze(1)
    return c, d, m


def forward(net: QNet, color: np.ndarray, height: np.ndarray, mask: np.ndarray, rotations: list[int]) -> torch.Tensor:
    """Q (1, len(rotations), H, W) with gradients (training)."""
    c, d, m = tensors(color, height, mask)
    return net(c, d, m, rotations)


@torch.inference_mode()
def q_maps(nets: dict[str, QNet], hm: Heightmap, mask: np.ndarray, roles: tuple[str, ...]) -> dict[str, np.ndarray]:
    """All-rotation Q maps {role: (R, H, W)} of the listed nets (all on one device), in eval mode, on the host."""
    c, d, m = tensors(hm.color, hm.height, mask, next(nets[roles[0]].parameters()).device)
    out = {}
    for role in roles:
        net = nets[role]
        net.eval()
        out[role] = net(c, d, m, None)[0].cpu().numpy()
    return out


def masked_max(q: np.ndarray, mask: np.ndarray) -> float:
    """Max of Q over the masked cells of every rotation; -1 when the mask is empty."""
    v = _masked_max(q, mask)
    return v if np.isfinite(v) else -1.0


def masked_argmax(q: np.ndarray, mask: np.ndarray) -> tuple[int, int, int]:
    """(rotation, row, col) of the masked maximum; the global one when the mask is empty."""
    if not mask.any():
        mask = np.ones(mask.shape, dtype=bool)
    r, row, col, _ = _masked_argmax(q, mask)
    return r, row, col


def push_region(goal: np.ndarray, geo: Geometry) -> np.ndarray:
    return _push_region(goal, geo.heightmap.resolution)


def action_pose(hm: Heightmap, primitive: str, rot: int, row: int, col: int, geo: Geometry):
    """(x, y, z, yaw) TCP target in `world` for the action."""
    return _action_pose(hm, primitive, rot, row, col, geo.primitives, rotations=geo.heightmap.rotations)


def color_at(hm: Heightmap, row: int, col: int) -> str | None:
    """Palette name of the object under a cell (nearest colour), None over the table."""
    if not hm.valid[row, col] or hm.height[row, col] < COLOR_HEIGHT_M:
        return None
    rgb = hm.color[row, col].astype(np.float64)
    names = list(COLORS)
    dist = []
    for n in names:  # distance to the palette colour under the best shading factor (sim shading scales RGB)
        ref = np.array(COLORS[n], dtype=np.float64)
        s = float(np.clip(rgb @ ref / (ref @ ref), 0.5, 1.1))
        dist.append(np.linalg.norm(rgb - s * ref))
    return names[int(np.argmin(dist))]
