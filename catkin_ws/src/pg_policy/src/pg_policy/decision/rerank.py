"""Re-rank the best cells of a Q map by a yes/no test, keeping the best value: shared by the test-time checks
(pg_policy.decision.rules.grasp_check on Q_g, pg_policy.decision.rules.edge_guard on Q_p), and over candidates a rule
proposes (pg_policy.decision.rules.grasp_search)."""

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


def rerank_among(q: np.ndarray, region: np.ndarray, allowed: Callable[[int, int, int], bool],
                 candidates: tuple[np.ndarray, np.ndarray, np.ndarray]) -> tuple[np.ndarray, int | None]:
    """`rerank` over given candidates instead of the map's best cells: (a float64 copy of the (R, H, W) map `q`, the
    number of cells of the region valued above the chosen one).

    `candidates` are (K,) int arrays (rotations, rows, cols), for instance a rule's geometric proposals
    (pg_policy.decision.rules.rule.Rule.proposals); those outside the (H, W) bool `region` or not finite in `q` are
    dropped, the others asked in descending value (ties in the order given). The first that `allowed` accepts takes
    the region's best value and every cell valued above it gets -inf, so the argmax over the region becomes that
    cell; none accepted: the copy is unchanged and the rank is None.
    """
    out = np.asarray(q, dtype=np.float64).copy()
    rots, rows, cols = (np.asarray(a, dtype=np.int64).reshape(-1) for a in candidates)
    if rots.size == 0:
        return out, None
    flat = np.ravel_multi_index((rots, rows, cols), out.shape)
    value = out.reshape(-1)[flat]
    keep = region[rows, cols] & np.isfinite(value)
    flat, value = flat[keep], value[keep]
    order = flat[np.argsort(-value, kind="stable")]
    rank = _first_allowed(order, out.shape, allowed)
    if rank is None:
        return out, None
    chosen = int(order[rank])
    masked = np.where(region[None] & np.isfinite(out), out, -np.inf).reshape(-1)
    above = masked > masked[chosen]
    best = float(masked.max())
    out.reshape(-1)[above] = -np.inf
    out.reshape(-1)[chosen] = best
    return out, int(above.sum())


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
