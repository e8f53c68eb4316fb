"""One long-lived thread that runs every policy computation of a process serving calls from many threads.

Why: rospy handles each service connection, and the node each action goal, on a thread of its own. glibc gives
threads their own malloc arenas (up to 8 per core), and a serving process keeps freed memory in every arena
(pg_policy.models.inference.keep_freed_memory: no trimming, no mmap), so a new thread that ran the nets could leave
their buffers (~200 MB) in yet another arena. Measured on sim.launch, one grasp_target call after another: run on
the calling threads, the policy node's RSS went 287 MB idle, 479 MB after one call, 717 MB after 17; run on one
thread, it stays at 563 MB from the 4th call to the 245th.

Contract: `call(fn, *args)` runs fn on the worker thread and returns its result or raises its exception in the
caller; a call made from the worker thread itself runs inline (no deadlock when a worker job calls back in). Calls
from several threads are served one after the other, in arrival order.
"""

from __future__ import annotations

import concurrent.futures
import threading
from collections.abc import Callable
from typing import Any, TypeVar

T = TypeVar("T")


class PinnedThread:
    """A single worker thread (started on first use, kept until `shutdown` or interpreter exit)."""

    def __init__(self, name: str = "pg_policy_worker") -> None:
        self._pool = concurrent.futures.ThreadPoolExecutor(max_workers=1, thread_name_prefix=name)
        self._ident: int | None = None

    def _run(self, fn: Callable[..., T], args: tuple[Any, ...], kwargs: dict[str, Any]) -> T:
        self._ident = threading.get_ident()
        return fn(*args, **kwargs)

    def call(self, fn: Callable[..., T], *args: Any, **kwargs: Any) -> T:
        if threading.get_ident() == self._ident:
            return fn(*args, **kwargs)
        return self._pool.submit(self._run, fn, args, kwargs).result()

    @property
    def ident(self) -> int | None:
        """The worker thread's id once it has run something, else None."""
        return self._ident

    def shutdown(self) -> None:
        self._pool.shutdown(wait=True)
