"""Q maps from a heightmap: the grasp and push nets (eager QNet or loaded TorchScript) behind one call.

`PolicyNets.q_maps(heightmap, mask)` -> {"grasp": (R, H, W) float32, "push": (R, H, W) float32}; Q[k, row, col] is the
value of the primitive at heightmap cell (row, col) with gripper yaw = rotations[k] * 360 / R degrees in `world`
(convention of `pg_policy.models.nets.qnet`). Runs under torch.inference_mode with the nets in eval mode; the number of
torch threads is the caller's business (torch.set_num_threads).
"""

from __future__ import annotations

import ctypes
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
import torch
from torch import Tensor, nn

from pg_core.heap_trim import NODE_ARENAS, cap_arenas
from pg_core.heightmap import Heightmap
from pg_policy.models.model_io import ModelLoadError, load_qnet
from pg_policy.models.nets.lite_window import LiteWindowQ, supports_windows, windowed_q
from pg_policy.models.nets.qnet import QNetConfig, build_qnet

ROLES = ("grasp", "push")
# QNet methods and attributes that `PolicyNets` uses: kept when a net is frozen
PRESERVED = ["rotate_inputs", "q_from_rotated", "rotate_inputs_window", "q_from_rotated_window", "forward_indexed",
             "use_mask", "num_rotations", "exact_margin", "config_json"]


_M_TRIM_THRESHOLD, _M_MMAP_MAX = -1, -4  # glibc mallopt parameters
MALLOC_ARENAS = NODE_ARENAS  # keep_freed_memory's cap on glibc malloc arenas


def keep_freed_memory() -> bool:
    """glibc only: serve every allocation from the heap and never give freed memory back to the OS (mallopt
    M_MMAP_MAX = 0, M_TRIM_THRESHOLD = max). Batched DenseNet activations (100+ MB each at 16 x 320 x 320) are
    otherwise mmap'ed and page-faulted anew on every call: measured 315 -> 170 ms per image at batch 16 (1 thread).
    Also at most MALLOC_ARENAS malloc arenas (M_ARENA_MAX): with trimming off every arena keeps its peak, and a
    ROS node serves each service connection on a new thread, which glibc gives a new arena up to 8 per core (the
    policy node grew 220 MB per 100 grasp_target calls that way). Process-wide; the process keeps its peak memory.
    Returns False where glibc's mallopt is unavailable."""
    try:
        libc = ctypes.CDLL("libc.so.6")
        return (bool(libc.mallopt(_M_MMAP_MAX, 0)) and bool(libc.mallopt(_M_TRIM_THRESHOLD, 2**31 - 1))
                and cap_arenas(MALLOC_ARENAS))
    except (OSError, AttributeError):
        return False


def optimize_for_cpu(net: nn.Module) -> torch.jit.ScriptModule:
    """A frozen TorchScript copy of `net` (weights become constants: conv+BN folding, fused ReLU): about 2x less CPU
    for the lite net, outputs within ~1e-5 of the original. Later changes to `net`'s weights are not seen."""
    net = net.eval()
    scripted = net if isinstance(net, torch.jit.ScriptModule) else torch.jit.script(net)
    return torch.jit.freeze(scripted, preserved_attrs=PRESERVED)
Window = tuple[int, int, int, int]  # (row0, row1, col0, col1), half-open, heightmap cells


def heightmap_tensors(heightmap: Heightmap, mask: np.ndarray,
                      device: str | torch.device = "cpu") -> tuple[Tensor, Tensor, Tensor]:
    """Net inputs from a heightmap: colour (1, 3, H, W) float32 in [0, 1], depth (1, 1, H, W) float32 metres,
    mask (1, 1, H, W) float32 {0, 1}. Raises ValueError for a mask of the wrong shape."""
    mask = np.asarray(mask)
    if mask.shape != heightmap.height.shape:
        raise ValueError(f"mask shape {mask.shape} != heightmap shape {heightmap.height.shape}")
    c = torch.from_numpy(np.ascontiguousarray(heightmap.color)).to(device).permute(2, 0, 1).unsqueeze(0).float()
    d = torch.from_numpy(np.ascontiguousarray(heightmap.height, dtype=np.float32)).to(device)[None, None]
    m = torch.from_numpy(np.ascontiguousarray(mask, dtype=np.float32)).to(device)[None, None]
    return c / 255.0, d, m


def target_window(mask: np.ndarray, margin: int) -> Window | None:
    """(row0, row1, col0, col1), half-open: the bounding box of the True cells of (H, W) `mask` grown by `margin`
    cells and clipped to the map; None if the mask is empty."""
    rows, cols = np.nonzero(mask)
    if rows.size == 0:
        return None
    h, w = mask.shape
    return (max(int(rows.min()) - margin, 0), min(int(rows.max()) + 1 + margin, h),
            max(int(cols.min()) - margin, 0), min(int(cols.max()) + 1 + margin, w))


class PolicyNets:
    """The grasp net and the push net (eager `QNet` or scripted, not traced: `rotate_inputs`/`q_from_rotated` are
    used); `metadata` holds each net's export metadata (empty for eager nets). optimize: use frozen copies
    (`optimize_for_cpu`; a snapshot of the weights, so leave it off for nets that are still training) and call
    `keep_freed_memory()` (process-wide allocator setting: meant for a process that serves the policy)."""

    def __init__(self, grasp: nn.Module, push: nn.Module, metadata: dict[str, dict[str, Any]] | None = None,
                 device: str | torch.device = "cpu", optimize: bool = False) -> None:
        self.device = torch.device(device)
        nets = {"grasp": grasp.to(self.device).eval(), "push": push.to(self.device).eval()}
        # exact windowed evaluators of lite nets (before freezing: they read the weights), see q_maps
        self.windowed: dict[str, LiteWindowQ] = {k: LiteWindowQ(v) for k, v in nets.items() if supports_windows(v)}
        self.nets: dict[str, nn.Module] = {k: optimize_for_cpu(v) if optimize else v for k, v in nets.items()}
        if optimize:
            keep_freed_memory()
        self.metadata = metadata or {role: {} for role in ROLES}
        rots = {int(net.num_rotations) for net in self.nets.values()}
        if len(rots) != 1:
            raise ValueError(f"grasp and push nets disagree on the number of rotations: {sorted(rots)}")
        self.num_rotations = rots.pop()

    @classmethod
    def from_files(cls, grasp_path: str | Path, push_path: str | Path, device: str | torch.device = "cpu",
                   check_geometry: bool = True, optimize: bool = True) -> PolicyNets:
        """Load two exported TorchScript files (see `pg_policy.models.model_io`); raises ModelLoadError (a ValueError)
        for a
        bad file or a file whose metadata names another role or another heightmap geometry."""

        nets, meta = {}, {}
        for role, path in (("grasp", grasp_path), ("push", push_path)):
            nets[role], meta[role] = load_qnet(path, check_geometry=check_geometry, map_location=device)
            if meta[role].get("role") != role:
                raise ModelLoadError(f"{path}: exported as the {meta[role].get('role')!r} net, expected {role!r}")
        return cls(nets["grasp"], nets["push"], meta, device, optimize)

    @classmethod
    def random(cls, backbone: str = "lite", goal: str = "mask", rotations: int = 16, seed: int = 0,
               optimize: bool = False, device: str | torch.device = "cpu") -> PolicyNets:
        """Untrained nets with a reproducible initialisation (benchmarks, tests)."""

        cfg = QNetConfig(backbone=backbone, goal=goal, rotations=rotations)
        return cls(build_qnet(cfg, seed=seed), build_qnet(cfg, seed=seed + 1), device=device, optimize=optimize)

    def exact_margin(self) -> int:
        """Smallest window margin (px) for which window maps equal the full maps; -1 if none exists (DenseNet)."""
        margins = [int(net.exact_margin) for net in self.nets.values()]
        return -1 if min(margins) < 0 else max(margins)

    def q_maps(self, heightmap: Heightmap, mask: np.ndarray, rotations: Sequence[int] | None = None,
               nets: Sequence[str] = ROLES, window: Window | None = None,
               margin: int | None = None) -> dict[str, np.ndarray]:
        """{role: Q (R, H, W) float32} for each role in `nets`, R = len(rotations) (default all, in index order).

        mask: (H, W) bool/{0, 1} goal mask (an input of "mask" nets only). window (row0, row1, col0, col1): compute
        only those cells; the maps are then (R, row1 - row0, col1 - col0) with [0, 0] at (row0, col0). Without
        `margin`, lite nets compute every layer only where the window needs it (`LiteWindowQ`: equal to the full
        maps, at a cost that follows the window's area); other nets, or an explicit `margin`, crop the rotated
        canvases to the window plus `margin` px of context (default `exact_margin()`, which makes them equal to the
        full maps; required when that is -1). The rotated inputs are computed once and shared by nets with the same
        goal variant. Raises ValueError for unknown roles, shapes or windows.
        """
        unknown = [n for n in nets if n not in self.nets]
        if unknown:
            raise ValueError(f"unknown nets {unknown}; known: {list(self.nets)}")
        rots = list(range(self.num_rotations)) if rotations is None else [int(r) for r in rotations]
        c, d, m = heightmap_tensors(heightmap, mask, self.device)
        h, w = d.shape[2], d.shape[3]
        if window is not None:
            window = [int(v) for v in window]
            if len(window) != 4 or not (0 <= window[0] < window[1] <= h and 0 <= window[2] < window[3] <= w):
                raise ValueError(f"window {window} is not (row0, row1, col0, col1) inside the {h} x {w} heightmap")
            exact_layers = margin is None and all(role in self.windowed for role in nets)
            margin = self.exact_margin() if margin is None else int(margin)
            if margin < 0:
                raise ValueError("these nets have no exact window margin: give `margin` (px) explicitly")
            if exact_layers:
                return self.q_windows(heightmap, mask, {role: tuple(window) for role in nets}, rots)
        out: dict[str, np.ndarray] = {}
        shared: dict[bool, tuple[Tensor, ...]] = {}
        # optimized_execution(False): TorchScript's profiling executor would re-specialise (seconds for DenseNet) on
        # every new input shape (window crops) for no measurable gain on CPU.
        with torch.inference_mode(), torch.jit.optimized_execution(False):
            for role in nets:
                net = self.nets[role]
                key = bool(net.use_mask)
                if window is None:
                    if key not in shared:
                        shared[key] = net.rotate_inputs(c, d, m, rots)
                    q = net.q_from_rotated(shared[key][0], shared[key][1], rots, h, w)
                else:
                    if key not in shared:
                        shared[key] = net.rotate_inputs_window(c, d, m, rots, window, margin)
                    cr, dr, origins = shared[key]
                    q = net.q_from_rotated_window(cr, dr, origins, rots, h, w, window)
                out[role] = q[0].float().cpu().numpy()
        return out

    def q_windows(self, heightmap: Heightmap, mask: np.ndarray, windows: dict[str, Window],
                  rotations: Sequence[int] | None = None) -> dict[str, np.ndarray]:
        """{role: Q (R, rows, cols) float32 of windows[role]} with each net's own window, as `q_maps(...,
        window=windows[role])` gives them; lite nets share one sampling of the rotated inputs (`windowed_q`).
        Raises ValueError for unknown roles or windows outside the map."""
        unknown = [n for n in windows if n not in self.nets]
        if unknown:
            raise ValueError(f"unknown nets {unknown}; known: {list(self.nets)}")
        if not all(role in self.windowed for role in windows):
            return {role: self.q_maps(heightmap, mask, rotations, (role,), win)[role] for role, win in windows.items()}
        rots = list(range(self.num_rotations)) if rotations is None else [int(r) for r in rotations]
        c, d, m = heightmap_tensors(heightmap, mask, self.device)
        roles = list(windows)
        with torch.inference_mode():
            qs = windowed_q([self.windowed[r] for r in roles], c, d, m, rots,
                            [tuple(int(v) for v in windows[r]) for r in roles])
        return {role: q.float().cpu().numpy() for role, q in zip(roles, qs, strict=True)}


QInference = PolicyNets
