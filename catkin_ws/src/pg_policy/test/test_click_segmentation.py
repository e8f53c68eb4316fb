"""The click-conditioned segmenter's window encoding and its post-processing (a scripted stand-in net)."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from pg_core.heightmap import Heightmap
from pg_policy.models.click_segmentation import ClickSegmentation
from pg_policy.models.nets.click_segmenter import IN_CHANNELS, ClickSegmenter, encode_window, paste_window

RES = 0.002
BOUNDS = np.array([[-0.224, 0.224], [-0.224, 0.224], [0.0, 0.4]])


def _hm(height: np.ndarray, color: np.ndarray | None = None) -> Heightmap:
    if color is None:
        color = np.full(height.shape + (3,), 200, np.uint8)
    return Heightmap(color, height.astype(np.float32), np.ones(height.shape, bool), RES, BOUNDS)


def test_window_round_trip_and_edges():
    rng = np.random.default_rng(0)
    color = rng.integers(0, 255, (224, 224, 3), dtype=np.uint8)
    height = rng.random((224, 224)).astype(np.float32) * 0.05
    valid = rng.random((224, 224)) > 0.1
    x = encode_window(color, height, valid, 5, 220, 64)  # a corner: most of the window lies off the grid
    assert x.shape == (IN_CHANNELS, 64, 64) and x.dtype == np.float32
    assert x[5, 32, 32] == pytest.approx(1.0)  # the click's Gaussian peaks at the window's centre
    assert np.allclose(x[0, 27:, :36], color[:37, 188:, 0] / 255.0)  # rows 0..36, cols 188..223 of the grid
    assert not x[:5, :27].any() and not x[:5, :, 36:].any()  # off the grid: zero
    back = paste_window(x[3], (224, 224), 5, 220)
    assert np.allclose(back[:37, 188:], height[:37, 188:] / 0.1)
    assert not back[37:].any() and not back[:, :188].any()


class _Threshold(torch.nn.Module):
    """A stand-in net: logits = +1 where the height channel exceeds 0.1 (1 cm), else -1."""

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return torch.where(x[:, 3:4] > 0.1, 1.0, -1.0)


@pytest.fixture
def threshold_model(tmp_path):
    path = tmp_path / "net.pt"
    torch.jit.script(_Threshold()).save(str(path))
    return ClickSegmentation(path)


def test_mask_keeps_the_clicked_component(threshold_model):
    height = np.zeros((224, 224))
    height[50:70, 50:70] = 0.03  # the clicked block
    height[50:70, 80:100] = 0.03  # another, apart
    mask = threshold_model.mask(_hm(height), 60, 60)
    assert mask[50:70, 50:70].all() and mask.sum() == 400  # the other block is not connected: left out


def test_click_beside_the_object_snaps_or_finds_nothing(threshold_model):
    height = np.zeros((224, 224))
    height[50:70, 50:70] = 0.03
    assert threshold_model.mask(_hm(height), 71, 60).sum() == 400  # 2 cells off the border: snapped
    assert not threshold_model.mask(_hm(height), 120, 120).any()  # bare table: nothing


def test_refusals(tmp_path, threshold_model):
    with pytest.raises(FileNotFoundError, match="not found"):
        ClickSegmentation(tmp_path / "missing.pt")
    with pytest.raises(ValueError, match="outside"):
        threshold_model.mask(_hm(np.zeros((224, 224))), 224, 3)


def test_untrained_net_runs_scripted(tmp_path):
    torch.manual_seed(0)
    path = tmp_path / "net.pt"
    torch.jit.script(ClickSegmenter().eval()).save(str(path))
    out = ClickSegmentation(path).probability(_hm(np.zeros((224, 224))), 100, 100)
    assert out.shape == (224, 224) and np.all((out >= 0) & (out <= 1))


def test_join_clicked_adds_the_parts_the_net_covers(threshold_model):
    height = np.zeros((224, 224))
    height[40:80, 40:80] = 0.06  # a vessel's wall ...
    height[50:70, 50:70] = 0.02  # ... around its floor, 4 cm lower: two segments
    height[40:80, 100:120] = 0.03  # another object, apart
    labels = np.zeros((224, 224), np.int32)
    labels[40:80, 40:80] = 1
    labels[50:70, 50:70] = 2
    labels[40:80, 100:120] = 3
    first = labels == 1
    mask = threshold_model.join_clicked(_hm(height), labels, first, 45, 60)
    assert np.array_equal(mask, (labels == 1) | (labels == 2))  # the floor joins, the object apart does not
    assert np.array_equal(threshold_model.join_clicked(_hm(height), labels, labels == 3, 60, 110), labels == 3)


def test_load_segmenter_specs(tmp_path, threshold_model):
    from pg_policy.models.click_segmentation import load_segmenter, shipped_path

    assert load_segmenter("none") is None
    shipped = load_segmenter("shipped")
    assert (shipped is None) == (not shipped_path().is_file())
    assert load_segmenter(str(threshold_model.path)).path == threshold_model.path
    with pytest.raises(FileNotFoundError, match="'shipped', 'none' or the path"):
        load_segmenter(str(tmp_path / "nope.pt"))


def test_follower_joins_parts_only_with_a_segmenter(threshold_model):
    from pg_core.heightmap import pixel_to_world
    from pg_policy.target_loop.target_spec import PointTarget, TargetFollower

    height = np.zeros((224, 224))
    color = np.full((224, 224, 3), (190, 160, 120), np.uint8)
    height[40:80, 40:80] = 0.06  # a wall ...
    height[50:70, 50:70] = 0.02  # ... and its floor 4 cm lower: two segments
    color[40:80, 40:80] = (200, 40, 40)
    color[50:70, 50:70] = (40, 40, 200)
    hm = _hm(height, color)
    x, y = pixel_to_world(44, 60, BOUNDS, RES)
    plain = TargetFollower(PointTarget(x, y), 0.1, "none").mask(hm)
    joined = TargetFollower(PointTarget(x, y), 0.1, str(threshold_model.path)).mask(hm)
    assert not plain[55:65, 55:65].any()  # the floor is another segment
    assert joined[55:65, 55:65].all() and (joined & plain).sum() == plain.sum()
    with pytest.raises(FileNotFoundError):
        TargetFollower(PointTarget(x, y), 0.1, "missing.pt")
