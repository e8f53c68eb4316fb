"""The policy node's memory stays flat over calls: the shipped `lite` policy deciding on the recorded protocol
heightmaps (tests/golden) through the node's TargetLoop, each call from a new thread while short-lived threads come
and go, as rospy serves service and topic connections. Every decision runs on the loop's one worker thread
(pg_policy.target_loop.worker). Run on the calling threads, the nets' buffers end up in ever more malloc arenas and
the RSS grows call after call: +43 to +72 % over this test's 12 measured calls, against +7 to +12 % on the worker.

RSS is compared peak to peak (the largest reading after each call, warm-up against measured calls): glibc unmaps a
non-main arena's top heap (64 MB) when it empties, so readings jump by that much without any growth. The bound
also catches an accumulation of two sets of Q maps (2 x 2 x 16 x 224 x 224 float32, 13 MB) per call.
"""

from __future__ import annotations

import json
import os
import threading
import time
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

GOLDEN = Path(__file__).resolve().parent / "golden"
WARM_UP = 6  # calls before the baseline: the first decisions allocate the nets' working memory
CALLS = 12
MAX_GROWTH = 0.25  # of the warm-up's peak RSS
CHURN_THREADS = 8  # short-lived threads alive at a time besides the calls


def rss_mb() -> float:
    with open("/proc/self/status") as f:
        for line in f:
            if line.startswith("VmRSS:"):
                return int(line.split()[1]) / 1024.0
    pytest.fail("no VmRSS in /proc/self/status")


def test_rss_is_flat_over_calls_from_new_threads() -> None:
    import torch

    from pg_core.heightmap import Heightmap
    from pg_policy.policies.registry import make_policy
    from pg_policy.target_loop.loop_types import StampedHeightmap
    from pg_policy.target_loop.target_loop import TargetLoop

    arrays = np.load(GOLDEN / "decisions.npz")
    recs = json.loads((GOLDEN / "decisions.json").read_text())
    picks = [k for k, r in enumerate(recs) if r["step"] == 0]  # the first view of every protocol scene
    observations = [(StampedHeightmap(Heightmap(arrays[f"color_{k}"], arrays[f"height_{k}"], arrays[f"valid_{k}"],
                                                recs[k]["resolution"], np.asarray(recs[k]["bounds"])), 1.0 + k),
                     recs[k]["target"]) for k in picks]
    before = torch.get_num_threads()
    torch.set_num_threads(1)
    try:
        loop = TargetLoop(make_policy("lite"), SimpleNamespace(), SimpleNamespace(), lambda: 0.0)
        errors: list[BaseException] = []

        def call(i: int) -> None:
            shm, target = observations[i % len(observations)]
            try:
                loop.infer_on(target, shm)
            except BaseException as exc:  # noqa: BLE001 - reported by the test thread
                errors.append(exc)

        def calls(first: int, n: int) -> float:
            """Peak RSS (MB) read after each of calls first .. first + n - 1, each on a new thread."""
            peak = 0.0
            for i in range(first, first + n):
                t = threading.Thread(target=call, args=(i,))
                t.start()
                t.join()
                peak = max(peak, rss_mb())
            return peak

        stop = threading.Event()

        def connection() -> None:  # a short-lived thread that allocates a little, as rospy's connection threads
            scratch = [bytearray(1000) for _ in range(100)]
            time.sleep(0.05)
            del scratch

        def churn() -> None:
            while not stop.is_set():
                threads = [threading.Thread(target=connection) for _ in range(CHURN_THREADS)]
                for t in threads:
                    t.start()
                for t in threads:
                    t.join()

        churner = threading.Thread(target=churn, daemon=True)
        churner.start()
        try:
            base = calls(0, WARM_UP)
            peak = calls(WARM_UP, CALLS)
        finally:
            stop.set()
            churner.join()
    finally:
        torch.set_num_threads(before)
    assert not errors, errors
    assert peak - base < MAX_GROWTH * base, (f"peak RSS grew from {base:.0f} MB to {peak:.0f} MB over {CALLS} calls "
                                             f"(pid {os.getpid()})")
