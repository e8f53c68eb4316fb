"""pg_policy.decision.rerank: the best accepted cell takes the best value; nothing accepted leaves the map as it was."""

import numpy as np

from pg_policy.decision.rerank import rerank


def test_the_best_accepted_cell_takes_the_best_value_and_those_above_it_are_dropped():
    q = np.zeros((2, 3, 3))
    q[0, 1, 1], q[1, 0, 0], q[1, 2, 2] = 0.9, 0.8, 0.7
    out, rank = rerank(q, np.ones((3, 3), bool), lambda r, row, col: (r, row, col) == (1, 2, 2), top_k=10)
    assert rank == 2 and out[1, 2, 2] == 0.9 and out[0, 1, 1] == -np.inf and out[1, 0, 0] == -np.inf


def test_cells_outside_the_region_or_beyond_top_k_are_not_considered():
    q = np.zeros((1, 2, 2))
    q[0, 0, 0], q[0, 1, 1] = 0.9, 0.5
    region = np.array([[False, True], [True, True]])
    out, rank = rerank(q, region, lambda r, row, col: (row, col) == (0, 0), top_k=10)
    assert rank is None and np.array_equal(out, q)
    out, rank = rerank(q, np.ones((2, 2), bool), lambda r, row, col: (row, col) == (1, 0), top_k=2)
    assert rank is None and np.array_equal(out, q)


def test_a_batch_test_is_asked_in_growing_batches_and_gives_the_one_by_one_rank():
    from pg_policy.decision.rules.rule import BatchTest

    rng = np.random.default_rng(0)
    q = rng.random((4, 10, 10))
    region = np.ones((10, 10), bool)
    accepted = {(3, 7, 2), (1, 4, 4), (0, 9, 9)}
    one = lambda r, row, col: (r, row, col) in accepted  # noqa: E731
    asked: list[int] = []

    def many(rots, rows, cols):
        asked.append(len(rots))
        return np.array([(int(a), int(b), int(c)) in accepted for a, b, c in zip(rots, rows, cols, strict=True)])

    out_one, rank_one = rerank(q, region, one, top_k=400)
    out_many, rank_many = rerank(q, region, BatchTest(many), top_k=400)
    assert rank_many == rank_one and np.array_equal(out_many, out_one)
    assert asked[:3] == [8, 16, 32][:len(asked)] and sum(asked) >= rank_one + 1
    assert BatchTest(many)(3, 7, 2) and not BatchTest(many)(3, 7, 3)
