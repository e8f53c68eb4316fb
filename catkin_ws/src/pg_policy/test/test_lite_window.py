"""Windowed Q of lite nets (pg_policy.models.nets.lite_window): every layer computed only where a window needs it
equals the full map there, for any window, eager or scripted, both goal variants and output strides."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from pg_core.heightmap import Heightmap
from pg_policy.models.inference import PolicyNets
from pg_policy.models.nets.lite_window import LiteWindowQ, supports_windows
from pg_policy.models.nets.qnet import QNetConfig, build_qnet

WINDOWS = ([30, 50, 40, 70], [0, 20, 70, 96], [76, 96, 0, 9], [47, 48, 11, 12], [0, 96, 0, 96], [90, 96, 90, 96])


def _inputs(h: int, w: int, seed: int):
    g = torch.Generator().manual_seed(seed)
    color = torch.rand(1, 3, h, w, generator=g)
    depth = torch.rand(1, 1, h, w, generator=g) * 0.08
    mask = (torch.rand(1, 1, h, w, generator=g) > 0.7).float()
    return color, depth, mask


def _net(backbone: str, goal: str, seed: int) -> torch.nn.Module:
    """A net whose batch norms are not the identity (random statistics), so that folding them is tested."""
    net = build_qnet(QNetConfig(backbone, goal), seed=seed)
    g = torch.Generator().manual_seed(seed + 100)
    with torch.no_grad():
        for m in net.modules():
            if isinstance(m, torch.nn.BatchNorm2d):
                m.running_mean.copy_(torch.randn(m.num_features, generator=g) * 0.1)
                m.running_var.copy_(torch.rand(m.num_features, generator=g) + 0.5)
                m.weight.copy_(torch.rand(m.num_features, generator=g) + 0.5)
                m.bias.copy_(torch.randn(m.num_features, generator=g) * 0.1)
    return net.eval()


@pytest.mark.parametrize(("backbone", "goal"), [("lite-os8", "mask"), ("lite", "mask"), ("lite-os8", "none")])
def test_every_window_equals_the_full_map(backbone, goal):
    net = _net(backbone, goal, seed=5)
    color, depth, mask = _inputs(96, 96, seed=6)
    mask_in = mask if goal == "mask" else None
    windowed = LiteWindowQ(net)
    with torch.no_grad():
        full = net(color, depth, mask_in)[0]
        for win in WINDOWS:
            q = windowed.q(color, depth, mask_in, list(range(16)), tuple(win))
            assert q.shape == (16, win[1] - win[0], win[3] - win[2])
            torch.testing.assert_close(q, full[:, win[0]:win[1], win[2]:win[3]], atol=2e-5, rtol=0)
        some = windowed.q(color, depth, mask_in, [3, 11], (10, 40, 20, 60))
        torch.testing.assert_close(some, full[[3, 11], 10:40, 20:60], atol=2e-5, rtol=0)


def test_a_scripted_net_gives_the_same_windows_and_other_trunks_are_refused():
    net = _net("lite-os8", "mask", seed=7)
    color, depth, mask = _inputs(64, 80, seed=8)
    scripted = torch.jit.script(net)
    with torch.no_grad():
        full = net(color, depth, mask)[0]
        q = LiteWindowQ(scripted).q(color, depth, mask, list(range(16)), (5, 30, 50, 80))
    torch.testing.assert_close(q, full[:, 5:30, 50:80], atol=2e-5, rtol=0)
    assert supports_windows(scripted) and not supports_windows(build_qnet(QNetConfig("densenet121", "mask")))
    with pytest.raises(ValueError, match="lite trunks"):
        LiteWindowQ(build_qnet(QNetConfig("densenet121", "mask")))
    with pytest.raises(ValueError, match="window inside the 64 x 80 map"):
        LiteWindowQ(net).q(color, depth, mask, [0], (0, 65, 0, 10))


def test_policy_nets_use_the_layer_windows_for_lite_and_the_input_crop_on_request():
    nets = PolicyNets.random(backbone="lite-os8", seed=2, optimize=True)
    assert set(nets.windowed) == {"grasp", "push"}
    rng = np.random.default_rng(0)
    h, w = 64, 64
    hm = Heightmap(height=(rng.random((h, w)) * 0.05).astype(np.float32),
                   color=rng.integers(0, 255, (h, w, 3), dtype=np.uint8), valid=np.ones((h, w), bool),
                   bounds=np.array([[-0.064, 0.064], [-0.064, 0.064], [0.0, 0.3]]), resolution=0.002)
    mask = rng.random((h, w)) > 0.8
    full = nets.q_maps(hm, mask)
    win = (10, 30, 20, 50)
    layered = nets.q_maps(hm, mask, window=win)
    cropped = nets.q_maps(hm, mask, window=win, margin=nets.exact_margin())
    for role in ("grasp", "push"):
        np.testing.assert_allclose(layered[role], full[role][:, 10:30, 20:50], atol=2e-5)
        np.testing.assert_allclose(cropped[role], full[role][:, 10:30, 20:50], atol=2e-5)


@pytest.mark.skipif(not torch.cuda.is_available(), reason="opt-in: no CUDA device on this machine")
def test_the_windowed_evaluator_runs_where_the_net_does():
    """A net on the GPU (`pushgrasp eval --device cuda`) has its windows computed on the GPU, equal to the CPU's."""
    net = _net("lite-os8", "mask", seed=9)
    color, depth, mask = _inputs(64, 64, seed=10)
    with torch.no_grad():
        cpu = LiteWindowQ(net).q(color, depth, mask, [0, 5], (8, 40, 16, 48))
        gpu_net = torch.jit.script(net).to("cuda")
        gpu = LiteWindowQ(gpu_net).q(color.cuda(), depth.cuda(), mask.cuda(), [0, 5], (8, 40, 16, 48))
    assert gpu.device.type == "cuda"
    torch.testing.assert_close(gpu.cpu(), cpu, atol=1e-4, rtol=0)
