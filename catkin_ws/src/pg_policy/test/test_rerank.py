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
