"""Training the click-conditioned segmenter: views, examples, the split, a short run that resumes and writes a
model the runtime loads; and views collected from the simulator."""

from __future__ import annotations

import numpy as np
import pytest

from pg_learning.segmentation.segmenter_training import (
    SegmenterTraining,
    View,
    example,
    innermost_cell,
    split,
    train,
)
from pg_policy.models.click_segmentation import ClickSegmentation


def _save_view(path, seed: int) -> None:
    rng = np.random.default_rng(seed)
    labels = np.full((64, 64), 0, np.int32)
    labels[10:30, 10:30] = 3
    labels[35:55, 20:50] = 4
    height = np.where(labels > 0, 0.03, 0.0).astype(np.float32)
    color = rng.integers(0, 255, (64, 64, 3), dtype=np.uint8)
    np.savez_compressed(path, color=color, height=height, valid=np.ones((64, 64), bool), labels=labels,
                        objects=np.array([3, 4], np.int32), target=np.int32(3))


def test_innermost_and_random_clicks_lie_inside():
    mask = np.zeros((40, 40), bool)
    mask[5:25, 10:20] = True
    assert innermost_cell(mask) in {(r, c) for r in range(13, 17) for c in range(13, 17)}
    rng = np.random.default_rng(0)
    for _ in range(20):
        r, c = innermost_cell(mask, rng)
        assert mask[r - 2:r + 3, c - 2:c + 3].all()  # at least 2 cells inside the border


def test_example_label_follows_the_clicked_object(tmp_path):
    _save_view(tmp_path / "v_300001_unique.npz", 0)
    view = View.load(tmp_path / "v_300001_unique.npz")
    assert view.clickable() == [3, 4]
    x, y = example(view, 4, 32, np.random.default_rng(1), augment=False)
    assert x.shape == (6, 32, 32) and y.shape == (32, 32)
    assert y[16, 16] == 1.0  # the click (the window's centre) lies on the object
    assert 20 * 20 <= y.sum() <= 600  # the object's cells within the window, no other object's
    assert not y[x[3] == 0].any()  # off the object (table) never labelled


def test_split_holds_out_by_seed(tmp_path):
    for seed in (300000, 300005, 300010, 300099, 300105):
        _save_view(tmp_path / f"fam-1_{seed}_unique.npz", seed)
    train_files, val = split(tmp_path, 0.1)
    assert sorted(int(f.stem.split("_")[1]) for f in val) == [300000, 300005, 300105]
    assert len(train_files) == 2
    with pytest.raises(FileNotFoundError):
        split(tmp_path / "none", 0.1)


def test_short_run_resumes_and_writes_a_loadable_model(tmp_path, capsys):
    views = tmp_path / "views"
    views.mkdir()
    for seed in (300011, 300012, 300013):
        _save_view(views / f"fam-1_{seed}_unique.npz", seed)
    args = SegmenterTraining(views=str(views), out=str(tmp_path / "run"), collect=0, steps=2, batch=2, window=32,
                             checkpoint_every=1, threads=1)
    path = train(args)
    model = ClickSegmentation(path)
    out = capsys.readouterr().out
    assert "step 0 of 2" in out
    train(SegmenterTraining(**{**args.__dict__, "steps": 3}))  # resumes at step 2
    assert "step 2 of 3" in capsys.readouterr().out
    assert model.mask.__self__ is model


def test_collect_writes_views_with_ground_truth(tmp_path):
    from pg_learning.segmentation.segmenter_views import collect

    paths = collect(["random-4"], 300000, 2, tmp_path)
    assert [p.name for p in paths] == ["random-4_300000_unique.npz", "random-4_300001_repeated.npz"]
    view = View.load(paths[0])
    assert len(view.objects) == 4 and set(view.clickable()) <= set(int(o) for o in view.objects)
    assert view.labels.shape == view.height.shape == view.valid.shape
    assert collect(["random-4"], 300000, 2, tmp_path) == paths  # kept: a rerun resumes
