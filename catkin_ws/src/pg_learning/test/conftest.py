"""Fixtures shared by pg_learning's tests: local Ray clusters of two nodes on this machine, and Ray workers that import
the test modules."""

from __future__ import annotations

import os
import subprocess
import time
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any

import pytest

RAY_PROCESSES = "raylet|gcs_server|ray::"


def ray_processes() -> list[str]:
    """Command lines of Ray's processes (raylets, GCS, workers) alive on this machine."""
    out = subprocess.run(["pgrep", "-af", RAY_PROCESSES], capture_output=True, text=True, timeout=10).stdout
    return [line for line in out.splitlines() if "pgrep" not in line]


def worker_path(monkeypatch: pytest.MonkeyPatch, folder: str) -> None:
    """Put `folder` first on the PYTHONPATH that Ray's workers get (pg_learning.cluster.ray_session.worker_env)."""
    monkeypatch.setenv("PYTHONPATH", os.pathsep.join(p for p in (folder, os.environ.get("PYTHONPATH")) if p))


@contextmanager
def two_nodes(object_store_bytes: int) -> Iterator[tuple[Any, Any]]:
    """(cluster, worker node): a head and a worker node with one CPU each (ray.cluster_utils.Cluster, each its own
    raylet), token authentication on, shut down on exit. The calling process is not connected: code under test
    connects with `cluster.address`."""
    from ray.cluster_utils import Cluster

    from pg_learning.cluster.ray_session import use_token_auth

    old_mode = os.environ.pop("RAY_AUTH_MODE", None)
    use_token_auth(create=True)  # the head requires a token; clients send it in token mode
    cluster = Cluster(initialize_head=True, connect=False,
                      head_node_args={"num_cpus": 1, "include_dashboard": False,
                                      "object_store_memory": object_store_bytes})
    try:
        node = cluster.add_node(num_cpus=1, object_store_memory=object_store_bytes)
        cluster.wait_for_nodes(timeout=60)
        yield cluster, node
    finally:
        cluster.shutdown()
        if old_mode is None:
            os.environ.pop("RAY_AUTH_MODE", None)
        else:
            os.environ["RAY_AUTH_MODE"] = old_mode


@pytest.fixture(scope="session")
def ray_two_nodes():
    """The address (HOST:PORT) of a two-node cluster (two_nodes) shared by the session's tests; after them no Ray
    process may be left behind."""
    before = set(ray_processes())
    with two_nodes(200 * 2**20) as (cluster, _):
        yield cluster.address
    deadline = time.monotonic() + 20
    while (left := set(ray_processes()) - before) and time.monotonic() < deadline:
        time.sleep(0.5)
    assert not left, f"Ray processes left behind: {sorted(left)}"


@pytest.fixture
def importable_here(request, monkeypatch):
    """Ray workers import the requesting test module's functions by name: its folder goes on their PYTHONPATH."""
    worker_path(monkeypatch, str(request.path.parent))


@pytest.fixture
def own_two_nodes():
    """two_nodes as a fixture, for a test that changes its cluster (e.g. removes a node): use it as
    `with own_two_nodes(bytes) as (cluster, node): ...`."""
    return two_nodes
