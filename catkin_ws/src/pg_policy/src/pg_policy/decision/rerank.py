"""Re-rank the best cells of a Q map by a yes/no test, keeping the best value: shared by the test-time checks
(pg_policy.decision.rules.grasp_check on Q_g, pg_policy.decision.rules.edge_guard on Q_p)."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np


def rerank(q: np.ndarray, region: np.ndarray, allowed: Callable[[int, int, int], bool],
           top_k: int) -> tuple[np.ndarray, int | None]:
    """(a float64 copy of the (R, H, W) map `q`, the rank of the chosen cell).

    The finite cells of `q` inside the (H, W) bool `region` are walked in descending value (at most `top_k`; equal
    values in the order numpy's argpartition over the whole map leaves them, which the golden decisions pin); the
    first (rotation, row, col) that `allowed` accepts takes the best value and the cells ranked above it get -inf,
    so the argmax over the region becomes that cell. When none is accepted (or the region holds
    no finite cell) the copy is unchanged and the rank is None.
    """
    out = np.asarray(q, dtype=np.float64).copy()
    masked = np.where(region[None] & np.isfinite(out), out, -np.inf).reshape(-1)
    k = min(top_k, int(np.isfinite(masked).sum()))
    if k == 0:
        return out, None
    order = np.argpartition(-masked, k - 1)[:k]
    order = order[np.argsort(-masked[order], kind="stable")]
    rank = _first_allowed(order, out.shape, allowed)
    if rank is None:
        return out, None
    if rank:
        r, row, col = np.unravel_index(int(order[rank]), out.shape)
        out.reshape(-1)[order[:rank]] = -np.inf
        out[r, row, col] = masked[order[0]]
    return out, rank


FIRST_BATCH = 8  # candidates asked at once first; each later batch is twice as large


def _first_allowed(order: np.ndarray, shape: tuple[int, ...], allowed: Callable[[int, int, int], bool]) -> int | None:
    """Rank in `order` (flat indices into `shape`) of the first candidate `allowed` accepts, None if none. A test with
    a `many` method (pg_policy.decision.rules.rule.BatchTest) is asked in batches of 8, 16, 32, ... candidates."""
    many = getattr(allowed, "many", None)
    if many is None:
        for rank, flat in enumerate(order):
            r, row, col = (int(i) for i in np.unravel_index(int(flat), shape))
            if allowed(r, row, col):
                return rank
        return None
    rots, rows, cols = np.unravel_index(order, shape)
    start, size = 0, FIRST_BATCH
    while start < len(order):
        stop = min(start + size, len(order))
        hits = np.flatnonzero(np.asarray(many(rots[start:stop], rows[start:stop], cols[start:stop]), dtype=bool))
        if hits.size:
            return start + int(hits[0])
        start, size = stop, 2 * size
    return None
