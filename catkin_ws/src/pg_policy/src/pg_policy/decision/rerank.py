"""Re-rank the best cells of a Q map by a yes/no test, keeping the best value: shared by the test-time checks
(pg_policy.decision.rules.grasp_check on Q_g, pg_policy.decision.rules.edge_guard on Q_p)."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np


def rerank(q: np.ndarray, region: np.ndarray, allowed: Callable[[int, int, int], bool],
           top_k: int) -> tuple[np.ndarray, int | None]:
    """(a float64 copy of the (R, H, W) map `q`, the rank of the chosen cell).

    The finite cells of `q` inside the (H, W) bool `region` are walked in descending value (at most `top_k`, ties
    in index order); the first (rotation, row, col) that `allowed` accepts takes the best value and the cells ranked
    above it get -inf, so the argmax over the region becomes that cell. When none is accepted (or the region holds
    no finite cell) the copy is unchanged and the rank is None.
    """
    out = np.asarray(q, dtype=np.float64).copy()
    masked = np.where(region[None] & np.isfinite(out), out, -np.inf).reshape(-1)
    k = min(top_k, int(np.isfinite(masked).sum()))
    if k == 0:
        return out, None
    order = np.argpartition(-masked, k - 1)[:k]
    order = order[np.argsort(-masked[order], kind="stable")]
    for rank, flat in enumerate(order):
        r, row, col = (int(i) for i in np.unravel_index(int(flat), out.shape))
        if allowed(r, row, col):
            if rank:
                out.reshape(-1)[order[:rank]] = -np.inf
                out[r, row, col] = masked[order[0]]
            return out, rank
    return out, None
