"""pg_policy.decision.rules.grasp_filter: spec parsing, the symmetric average and the spatial filters against hand
computations."""

from __future__ import annotations

import numpy as np
import pytest

from pg_policy.decision.rules.grasp_filter import GraspFilter


@pytest.mark.parametrize("spec, expected", [(None, "none"), ("", "none"), ("none", "none"), ("sym", "sym"),
                                            ("min3", "min3"), ("MEAN5", "mean5"), ("sym+min3", "sym+min3"),
                                            ("min3+sym", "sym+min3")])
def test_parse_round_trips(spec, expected):
    f = GraspFilter.parse(spec)
    assert str(f) == expected and GraspFilter.parse(str(f)) == f
    assert f.active == (expected != "none")


@pytest.mark.parametrize("spec", ["min", "min2", "min1", "max3", "sym+sym", "min3+mean5", "sym+", "3"])
def test_bad_specs_name_the_accepted_forms(spec):
    with pytest.raises(ValueError, match="bad grasp filter.*sym"):
        GraspFilter.parse(spec)


def test_none_returns_the_input_and_shapes_are_checked():
    q = np.zeros((4, 5, 5), np.float32)
    assert GraspFilter().apply(q) is q
    with pytest.raises(ValueError, match=r"\(R, H, W\)"):
        GraspFilter.parse("min3").apply(np.zeros((5, 5)))
    with pytest.raises(ValueError, match="even number"):
        GraspFilter.parse("sym").apply(np.zeros((3, 5, 5)))


def test_sym_averages_each_rotation_with_its_opposite():
    rng = np.random.default_rng(0)
    q = rng.random((16, 6, 7)).astype(np.float32)
    out = GraspFilter.parse("sym").apply(q)
    assert out.dtype == np.float64 and out.shape == q.shape
    for r in range(16):
        np.testing.assert_allclose(out[r], 0.5 * (q[r] + q[(r + 8) % 16]), rtol=1e-6)
    np.testing.assert_allclose(out[:8], out[8:])


def test_min3_is_the_worst_of_each_cell_square_per_rotation():
    q = np.ones((2, 7, 7))
    q[0, 3, 3] = 5.0  # an isolated peak is removed ...
    q[1, 1:6, 1:6] = 3.0  # ... a plateau keeps its inside
    q[1, 5, 5] = 0.0  # one bad cell spoils its 3 x 3 neighbourhood only
    out = GraspFilter.parse("min3").apply(q)
    assert out[0].max() == 1.0
    assert out[1, 3, 3] == 3.0 and out[1, 4, 4] == 0.0 and out[1, 2, 2] == 3.0 and out[1, 1, 1] == 1.0
    assert out[0, 0, 0] == 1.0  # edges repeat the border ("nearest"), they are not padded with zeros


def test_mean3_is_the_cell_square_average():
    q = np.zeros((1, 5, 5))
    q[0, 2, 2] = 9.0
    out = GraspFilter.parse("mean3").apply(q)
    assert np.isclose(out[0, 1:4, 1:4], 1.0).all() and out.sum() == pytest.approx(9.0)


def test_min_filter_moves_the_argmax_off_a_speckle_onto_a_plateau():
    q = np.full((1, 9, 9), 0.2)
    q[0, 1, 1] = 0.95  # a one-cell speckle (the raw argmax)
    q[0, 4:8, 4:8] = 0.8  # a confident area
    out = GraspFilter.parse("min3").apply(q)
    assert np.unravel_index(np.argmax(q), q.shape) == (0, 1, 1)
    r, row, col = np.unravel_index(np.argmax(out), out.shape)
    assert 5 <= row <= 6 and 5 <= col <= 6 and out.max() == pytest.approx(0.8)


@pytest.mark.parametrize("spec", ["min3", "mean5", "sym+min3", "sym+mean3"])
def test_a_windowed_map_is_filtered_on_its_box_and_matches_the_full_map_inside(spec):
    # the learned policy's q_window: Q is finite on a box of cells, -inf around it (a running-sum mean over -inf
    # would give NaN across whole rows)
    rng = np.random.default_rng(3)
    full = rng.random((16, 40, 50))
    windowed = np.full_like(full, -np.inf)
    windowed[:, 10:30, 5:35] = full[:, 10:30, 5:35]
    f = GraspFilter.parse(spec)
    got, want = f.apply(windowed), f.apply(full)
    reach = f.size // 2
    inner = (slice(None), slice(10 + reach, 30 - reach), slice(5 + reach, 35 - reach))
    np.testing.assert_allclose(got[inner], want[inner])
    assert not np.isnan(got).any()
    assert np.isneginf(got[:, :10]).all() and np.isneginf(got[:, :, 35:]).all()
