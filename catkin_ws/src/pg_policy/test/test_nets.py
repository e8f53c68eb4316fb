"""Nets: DenseNet-121 names/shapes vs torchvision's layout, pretrained loading, lite trunk, QNet rotations/scripting."""

from __future__ import annotations

import numpy as np
import pytest
import torch
import torch.nn.functional as F

from pg_policy.models.nets import BACKBONES, QNetConfig, build_qnet, canvas_size
from pg_policy.models.nets.densenet import DenseNet121Trunk, PretrainedError, load_pretrained, rename_legacy_keys
from pg_policy.models.nets.lite import LiteTrunk

torch.set_num_threads(2)


def expected_densenet121_features() -> dict[str, tuple[int, ...]]:
    """torchvision densenet121().features state_dict layout, derived from the architecture (growth 32, blocks
    (6, 12, 24, 16), bn_size 4, 64 initial features), independently of our module."""
    keys: dict[str, tuple[int, ...]] = {}

    def bn(name: str, ch: int) -> None:
        for p in ("weight", "bias", "running_mean", "running_var"):
            keys[f"{name}.{p}"] = (ch,)
        keys[f"{name}.num_batches_tracked"] = ()

    keys["features.conv0.weight"] = (64, 3, 7, 7)
    bn("features.norm0", 64)
    ch = 64
    for b, n in enumerate((6, 12, 24, 16), start=1):
        for i in range(n):
            pre = f"features.denseblock{b}.denselayer{i + 1}"
            cin = ch + i * 32
            bn(f"{pre}.norm1", cin)
            keys[f"{pre}.conv1.weight"] = (128, cin, 1, 1)
            bn(f"{pre}.norm2", 128)
            keys[f"{pre}.conv2.weight"] = (32, 128, 3, 3)
        ch += n * 32
        if b < 4:
            bn(f"features.transition{b}.norm", ch)
            keys[f"features.transition{b}.conv.weight"] = (ch // 2, ch, 1, 1)
            ch //= 2
    bn("features.norm5", ch)
    assert ch == 1024
    return keys


def test_densenet_state_dict_matches_torchvision_layout():
    expected = expected_densenet121_features()
    got = {k: tuple(v.shape) for k, v in DenseNet121Trunk().state_dict().items()}
    assert list(got) == list(expected)  # same names, same order
    assert got == expected
    assert len(expected) == 11 + 58 * 12 + 3 * 6 == 725  # conv0/norm0/norm5 + dense layers + transitions
    n_params = sum(p.numel() for p in DenseNet121Trunk().parameters())
    assert n_params == 7_978_856 - (1024 * 1000 + 1000)  # torchvision's total minus the classifier


def _torchvision_style_file(tmp_path, trunk: DenseNet121Trunk, legacy: bool = False, prefix: str = "") -> str:
    state = dict(trunk.state_dict())
    state["classifier.weight"] = torch.zeros(1000, 1024)
    state["classifier.bias"] = torch.zeros(1000)
    if legacy:  # 'denselayer1.norm1.weight' -> 'denselayer1.norm.1.weight' as in old torchvision checkpoints
        state = {k.replace(".norm1.", ".norm.1.").replace(".conv2.", ".conv.2.") if "denselayer" in k else k: v
                 for k, v in state.items() if not k.endswith("num_batches_tracked")}
    path = tmp_path / "densenet121.pth"
    torch.save({prefix + k: v for k, v in state.items()}, path)
    return str(path)


@pytest.mark.parametrize("legacy,prefix", [(False, ""), (True, ""), (False, "module.")])
def test_load_pretrained_roundtrip(tmp_path, legacy, prefix):
    torch.manual_seed(1)
    src = DenseNet121Trunk()
    with torch.no_grad():
        for m in src.modules():
            if isinstance(m, torch.nn.BatchNorm2d):
                m.running_mean.uniform_(-1, 1)
    path = _torchvision_style_file(tmp_path, src, legacy, prefix)
    dst = DenseNet121Trunk()
    load_pretrained(dst, path)
    for (k, a), (k2, b) in zip(src.state_dict().items(), dst.state_dict().items(), strict=True):
        assert k == k2 and torch.equal(a, b), k


def test_rename_legacy_keys():
    t = torch.zeros(1)
    out = rename_legacy_keys({"features.denseblock1.denselayer1.norm.1.weight": t, "features.conv0.weight": t})
    assert set(out) == {"features.denseblock1.denselayer1.norm1.weight", "features.conv0.weight"}


def test_load_pretrained_errors(tmp_path):
    trunk = DenseNet121Trunk()
    with pytest.raises(FileNotFoundError, match="not found"):
        load_pretrained(trunk, tmp_path / "missing.pth")
    bad = tmp_path / "bad.pth"
    bad.write_bytes(b"not a checkpoint at all")
    with pytest.raises(PretrainedError, match="cannot read"):
        load_pretrained(trunk, bad)
    good = _torchvision_style_file(tmp_path, trunk)
    state = torch.load(good, weights_only=True)
    del state["features.norm5.weight"]
    state["features.conv0.weight"] = torch.zeros(64, 3, 3, 3)
    torch.save(state, tmp_path / "wrong.pth")
    with pytest.raises(PretrainedError, match="1 missing.*1 with wrong shapes"):
        load_pretrained(trunk, tmp_path / "wrong.pth")
    with pytest.raises(ValueError, match="no pretrained"):
        build_qnet(QNetConfig("lite", pretrained=good))


def test_qnet_loads_pretrained_into_both_trunks(tmp_path):
    torch.manual_seed(3)
    src = DenseNet121Trunk()
    path = _torchvision_style_file(tmp_path, src)
    net = build_qnet(QNetConfig("densenet121", pretrained=path))
    for trunk in (net.color_trunk, net.depth_trunk):
        assert torch.equal(trunk.features.conv0.weight, src.features.conv0.weight)


def test_lite_trunk_interface():
    trunk = LiteTrunk().eval()
    n = sum(p.numel() for p in trunk.parameters())
    assert 100_000 <= n <= 500_000
    with torch.no_grad():
        y = trunk(torch.zeros(2, 3, 64, 96))
    assert y.shape == (2, trunk.out_channels, 64 // trunk.stride, 96 // trunk.stride)
    assert set(BACKBONES) == {"densenet121", "lite", "lite-os8"}
    with pytest.raises(ValueError, match="output stride"):
        LiteTrunk(output_stride=4)


def test_lite_os8_is_lite_sampled_twice_as_densely():
    torch.manual_seed(0)
    lite, dense = LiteTrunk().eval(), LiteTrunk(output_stride=8).eval()
    for m in lite.modules():  # non-trivial BN statistics
        if isinstance(m, torch.nn.BatchNorm2d):
            m.running_mean.uniform_(-0.1, 0.1)
            m.running_var.uniform_(0.5, 1.5)
    dense.load_state_dict(lite.state_dict())  # same parameters
    x = torch.rand(1, 3, 96, 128)
    shifted = F.pad(x, (4, 0, 4, 0))[:, :, :96, :128]
    with torch.no_grad():
        y = dense(x)
        assert y.shape == (1, 128, 12, 16) and dense.stride == 8
        torch.testing.assert_close(y[:, :, ::2, ::2], lite(shifted), atol=1e-5, rtol=0)
        torch.testing.assert_close(torch.jit.script(dense)(x), y, atol=1e-5, rtol=0)


def test_lite_os8_window_equals_full_map():
    net = build_qnet(QNetConfig("lite-os8", "mask"), seed=3).eval()
    color, depth, mask = _inputs(96, 96, seed=4)
    with torch.no_grad():
        full = net(color, depth, mask)
        for win in ([30, 50, 40, 70], [0, 20, 70, 96], [76, 96, 0, 9]):
            cr, dr, origins = net.rotate_inputs_window(color, depth, mask, None, win, net.exact_margin)
            q = net.q_from_rotated_window(cr, dr, origins, None, 96, 96, win)
            torch.testing.assert_close(q, full[:, :, win[0]:win[1], win[2]:win[3]], atol=2e-5, rtol=0)


def test_config_validation():
    with pytest.raises(ValueError, match="unknown backbone"):
        QNetConfig("resnet")
    with pytest.raises(ValueError, match="goal"):
        QNetConfig("lite", goal="depth")
    assert QNetConfig.from_dict(QNetConfig("lite", "mask").to_dict()) == QNetConfig("lite", "mask")
    assert canvas_size(224, 224) == 320 and canvas_size(32, 32) == 64


def _inputs(h: int = 48, w: int = 48, b: int = 1, seed: int = 0):
    g = torch.Generator().manual_seed(seed)
    color = torch.rand(b, 3, h, w, generator=g)
    depth = torch.rand(b, 1, h, w, generator=g) * 0.08
    mask = (torch.rand(b, 1, h, w, generator=g) > 0.7).float()
    return color, depth, mask


@pytest.fixture(scope="module")
def lite_mask():
    return build_qnet(QNetConfig("lite", "mask"), seed=0)


def test_qnet_shapes_subsets_batches(lite_mask):
    color, depth, mask = _inputs(48, 64, b=2)
    with torch.no_grad():
        q = lite_mask(color, depth, mask)
        assert q.shape == (2, 16, 48, 64) and q.dtype == torch.float32
        sub = lite_mask(color, depth, mask, [3, 11])
        torch.testing.assert_close(sub, q[:, [3, 11]], atol=1e-5, rtol=0)
        one = lite_mask(color[1:], depth[1:], mask[1:])
        torch.testing.assert_close(one, q[1:], atol=1e-5, rtol=0)
        idx = lite_mask.forward_indexed(color, depth, mask, torch.tensor([5, 9]))
        torch.testing.assert_close(idx, torch.stack([q[0, 5], q[1, 9]]), atol=1e-5, rtol=0)


def test_qnet_input_errors(lite_mask):
    color, depth, mask = _inputs()
    with pytest.raises(ValueError, match="mask is required"):
        lite_mask(color, depth)
    with pytest.raises(ValueError, match="out of range"):
        lite_mask(color, depth, mask, [16])
    with pytest.raises(ValueError, match="depth must be"):
        lite_mask(color, depth[:, :, :10], mask)
    build_qnet(QNetConfig("lite", "none"))(color, depth)  # goal "none" needs no mask


def test_rotation_convention_world_direction(lite_mask):
    """A cell at distance L from the centre along world yaw theta_r appears ~L px along +col of rotated map r."""
    h = w = 48
    p = canvas_size(h, w)  # 96: heightmap cell (24, 24) is canvas cell (48, 48), centre (48.5, 48.5)
    for r, (dx, dy) in {0: (10, 0), 4: (0, 10), 8: (-10, 0), 12: (0, -10), 2: (7, 7), 6: (-7, 7)}.items():
        depth = torch.zeros(1, 1, h, w)
        depth[0, 0, 24 + dy, 24 + dx] = 1.0  # row = world y, col = world x
        _, d_rot = lite_mask.rotate_inputs(torch.zeros(1, 3, h, w), depth, torch.zeros_like(depth), [r])
        img = d_rot[0, 0].numpy()
        row, col = np.unravel_index(np.argmax(img), img.shape)
        length = float(np.hypot(dx, dy))
        assert abs(row + 0.5 - p / 2) <= 1.0 and abs(col + 0.5 - (p / 2 + length)) <= 1.0, (r, row, col)


def test_rotation_90_is_rot90(lite_mask):
    color, depth, mask = _inputs(48, 48)
    rot = [torch.from_numpy(np.ascontiguousarray(np.rot90(t.numpy(), 1, axes=(2, 3)))) for t in (color, depth, mask)]
    with torch.no_grad():
        c4, d4 = lite_mask.rotate_inputs(color, depth, mask, [4])
        c0, d0 = lite_mask.rotate_inputs(*rot, [0])
        torch.testing.assert_close(c4, c0, atol=1e-4, rtol=0)  # grid_sample (un)normalisation rounding
        torch.testing.assert_close(d4, d0, atol=1e-4, rtol=0)
        q4 = lite_mask(color, depth, mask, [4])[0, 0].numpy()
        q0 = lite_mask(*rot, [0])[0, 0].numpy()
    np.testing.assert_allclose(np.rot90(q0, -1), q4, atol=1e-4)


def test_rotation_matches_reference_affine_grid(lite_mask):
    """Our canvases = VPG's recipe: zero-pad raw inputs, affine_grid with [[cos, -sin], [sin, cos]], normalise."""
    color, depth, mask = _inputs(40, 40)
    theta = 3 * 2 * np.pi / 16
    p = canvas_size(40, 40)
    pad = (p - 40) // 2
    raw = F.pad(torch.cat([color, depth, mask], 1), [pad] * 4)
    mat = torch.tensor([[[np.cos(theta), -np.sin(theta), 0.0], [np.sin(theta), np.cos(theta), 0.0]]],
                       dtype=torch.float32)
    rot = F.grid_sample(raw, F.affine_grid(mat, [1, 5, p, p], align_corners=False), align_corners=False)
    mean = torch.tensor([0.485, 0.456, 0.406]).view(1, 3, 1, 1)
    std = torch.tensor([0.229, 0.224, 0.225]).view(1, 3, 1, 1)
    d = (rot[:, 3:4] - 0.01) / 0.03
    c_ref, d_ref = (rot[:, :3] - mean) / std, torch.cat([d, d, (rot[:, 4:5] - 0.5) / 0.5], 1)
    c_rot, d_rot = lite_mask.rotate_inputs(color, depth, mask, [3])
    torch.testing.assert_close(c_rot, c_ref, atol=1e-4, rtol=0)
    torch.testing.assert_close(d_rot, d_ref, atol=1e-4, rtol=0)


def test_unrotate_at_r0_is_bilinear_upsample_crop(lite_mask):
    color, depth, mask = _inputs(48, 48)
    with torch.no_grad():
        c, d = lite_mask.rotate_inputs(color, depth, mask, [0])
        low = lite_mask._q_low(c, d)
        p = canvas_size(48, 48)
        top = (p - 48) // 2
        ref = F.interpolate(low, size=(p, p), mode="bilinear", align_corners=False)[0, 0, top:top + 48, top:top + 48]
        q = lite_mask(color, depth, mask, [0])[0, 0]
    torch.testing.assert_close(q, ref, atol=1e-5, rtol=0)


def test_window_equals_full_map_with_exact_margin(lite_mask):
    color, depth, mask = _inputs(96, 96, seed=2)
    with torch.no_grad():
        full = lite_mask(color, depth, mask)
        for win in ([30, 50, 40, 70], [0, 20, 70, 96]):
            cr, dr, origins = lite_mask.rotate_inputs_window(color, depth, mask, None, win, lite_mask.exact_margin)
            q = lite_mask.q_from_rotated_window(cr, dr, origins, None, 96, 96, win)
            torch.testing.assert_close(q, full[:, :, win[0]:win[1], win[2]:win[3]], atol=2e-5, rtol=0)


class _FixedRotations(torch.nn.Module):
    """Trace wrapper: forward(color, depth, mask) with a fixed rotation list."""

    def __init__(self, net: torch.nn.Module, rotations: list[int]) -> None:
        super().__init__()
        self.net, self.rotations = net, rotations

    def forward(self, color, depth, mask):
        return self.net(color, depth, mask, self.rotations)


@pytest.mark.parametrize("backbone,goal", [("lite", "none"), ("lite", "mask"), ("lite-os8", "none"),
                                          ("densenet121", "none"), ("densenet121", "mask")])
def test_script_matches_eager(backbone, goal):
    net = build_qnet(QNetConfig(backbone, goal), seed=0)
    color, depth, mask = _inputs(32, 32)
    rots = [0, 3] if backbone.startswith("lite") else [5]
    with torch.no_grad(), torch.jit.optimized_execution(False):  # skip the profiling executor's slow passes
        scripted = torch.jit.script(net)
        torch.testing.assert_close(scripted(color, depth, mask, rots), net(color, depth, mask, rots), atol=1e-5,
                                   rtol=0)


@pytest.mark.parametrize("goal", ["none", "mask"])
def test_trace_matches_eager(goal):
    """Tracing works too (fixed shape and rotations); DenseNet-121 is covered by scripting (tracing it is slow)."""
    net = build_qnet(QNetConfig("lite", goal), seed=0)
    color, depth, mask = _inputs(32, 32)
    with torch.no_grad(), torch.jit.optimized_execution(False):
        traced = torch.jit.trace(_FixedRotations(net, [0, 3]), (color, depth, mask), check_trace=False)
        torch.testing.assert_close(traced(color, depth, mask), net(color, depth, mask, [0, 3]), atol=1e-5, rtol=0)
