"""Fixtures shared by pg_policy's tests: a local two-node Ray cluster on this machine."""

from __future__ import annotations

import os
import subprocess
import time

import pytest

RAY_PROCESSES = "raylet|gcs_server|ray::"


def ray_processes() -> list[str]:
    """Command lines of Ray's processes (raylets, GCS, workers) alive on this machine."""
    out = subprocess.run(["pgrep", "-af", RAY_PROCESSES], capture_output=True, text=True, timeout=10).stdout
    return [line for line in out.splitlines() if "pgrep" not in line]


@pytest.fixture(scope="session")
def ray_two_nodes():
    """The address (HOST:PORT) of a Ray cluster of two nodes with one CPU each, started here with
    ray.cluster_utils.Cluster (a head and a worker node, each its own raylet) and shut down after the tests, leaving
    no Ray process behind. The test process itself is not connected: code under test connects with the address."""
    pytest.importorskip("ray")
    from ray.cluster_utils import Cluster

    from pg_policy.cluster.ray_session import use_token_auth

    before = set(ray_processes())
    old_mode = os.environ.get("RAY_AUTH_MODE")
    os.environ.pop("RAY_AUTH_MODE", None)
    use_token_auth(create=True)  # the head requires a token; clients send it in token mode
    cluster = Cluster(initialize_head=True, connect=False,
                      head_node_args={"num_cpus": 1, "include_dashboard": False, "object_store_memory": 200 * 2**20})
    try:
        cluster.add_node(num_cpus=1, object_store_memory=200 * 2**20)
        cluster.wait_for_nodes(timeout=60)
        yield cluster.address
    finally:
        cluster.shutdown()
        if old_mode is None:
            os.environ.pop("RAY_AUTH_MODE", None)
        else:
            os.environ["RAY_AUTH_MODE"] = old_mode
        deadline = time.monotonic() + 20
        while (left := set(ray_processes()) - before) and time.monotonic() < deadline:
            time.sleep(0.5)
        assert not left, f"Ray processes left behind: {sorted(left)}"
