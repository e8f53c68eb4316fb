"""Ray for pushgrasp: a local Ray of N CPUs, or a connection to a running cluster, as one context manager.

``ray_session(cpus, address)`` starts a local Ray with ``cpus`` CPUs (``address`` None) or connects to a cluster
(``address`` "auto" or "HOST:PORT", the head's GCS port, 6379 by default with ``ray start --head``), and shuts Ray
down on exit (a local Ray's processes end with it; a cluster keeps running). Ray's own import is deferred to the call.

A local Ray is a node of address 127.0.0.1: its GCS server, raylet, workers and agents listen on loopback only
(``local_ray_address``). A cluster is used as its head was started (docs/CLUSTER.md).

Every wait is bounded: ``ray.init`` retries an unreachable GCS for minutes, so the address is first checked with a TCP
connection of ``CONNECT_TIMEOUT_S``; an address that does not answer raises ConnectionError naming it.

Workers on other nodes import the project from their own install: every node needs the same checkout and venv at the
same path (docs/CLUSTER.md). The environment variables named ``PG_*`` and ``PYTHONPATH`` of the caller are passed to
every worker (``runtime_env``), so e.g. ``$PG_WORKSPACE_CONFIG`` means the same file everywhere.
"""

from __future__ import annotations

import logging
import os
import socket
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

CONNECT_TIMEOUT_S = 5.0
LOCAL_OBJECT_STORE_BYTES = 512 * 1024**2  # trial records and transitions are small (a heightmap is ~0.4 MB)
CURRENT_CLUSTER_FILE = Path("/tmp/ray/ray_current_cluster")  # written by `ray start --head` on this machine
LOCAL_NODE_ADDRESS = "127.0.0.1"  # the node address of a local Ray: every port it opens is on loopback


@dataclass(frozen=True)
class RayInfo:
    """What a session runs on: its address ("local" for one started here), nodes alive and CPUs in all."""

    address: str
    nodes: int
    cpus: int


def resolve_address(address: str) -> str:
    """HOST:PORT of `address`: "auto" is $RAY_ADDRESS, else the cluster that `ray start --head` on this machine
    recorded. Raises ConnectionError when "auto" finds none and ValueError for a malformed address."""
    if address == "auto":
        found = os.environ.get("RAY_ADDRESS") or (
            CURRENT_CLUSTER_FILE.read_text().strip() if CURRENT_CLUSTER_FILE.is_file() else "")
        if not found:
            raise ConnectionError("--ray-address auto: no Ray cluster runs on this machine (start one with "
                                  "`ray start --head`, or give HOST:PORT of the head node)")
        address = found
    host, sep, port = address.removeprefix("ray://").rpartition(":")
    if not sep or not host or not port.isdigit():
        raise ValueError(f"Ray address {address!r} is not HOST:PORT (the head's GCS port, e.g. 10.0.0.5:6379) or "
                         "'auto'")
    return f"{host}:{port}"


def check_reachable(address: str, timeout_s: float = CONNECT_TIMEOUT_S) -> None:
    """Raise ConnectionError unless a TCP connection to HOST:PORT `address` opens within `timeout_s`."""
    host, _, port = address.rpartition(":")
    try:
        with socket.create_connection((host, int(port)), timeout=timeout_s):
            pass
    except OSError as exc:
        raise ConnectionError(f"no Ray head answers at {address} within {timeout_s:.0f} s ({exc}); start it with "
                              "`ray start --head --port PORT` or check the address") from exc


def use_token_auth(create: bool = False) -> None:
    """Token authentication for a connection to an existing cluster. Ray 2.60 heads require the cluster's token
    (~/.ray/auth_token, $RAY_AUTH_TOKEN or $RAY_AUTH_TOKEN_PATH), but a client that connects by address sends it only
    in token mode, and Ray reads the mode once, when imported. So: token mode when $RAY_AUTH_MODE is unset and a token
    exists (or $RAY_AUTH_MODE is "token"), and Ray's cached configuration refreshed; `create` makes a token when there
    is none (for a cluster started by this process). $RAY_AUTH_MODE=disabled is respected."""
    from ray._private.authentication.authentication_token_setup import ensure_token_if_auth_enabled
    from ray._raylet import AuthenticationTokenLoader, Config

    mode = os.environ.get("RAY_AUTH_MODE")
    if mode is None and (create or AuthenticationTokenLoader.instance().has_token(ignore_auth_mode=True)):
        os.environ["RAY_AUTH_MODE"] = mode = "token"
    if mode is not None and mode.lower() == "token":
        Config.initialize("")
        ensure_token_if_auth_enabled(None, create_token_if_missing=create)


def worker_env() -> dict[str, str]:
    """The caller's environment that workers need: PG_* variables and PYTHONPATH."""
    return {k: v for k, v in os.environ.items() if k.startswith("PG_") or k == "PYTHONPATH"}


@contextmanager
def ray_session(cpus: int, address: str | None = None) -> Iterator[RayInfo]:
    """Ray for the duration of the block (module docstring). `cpus` >= 1 sizes a local Ray and is ignored for a
    cluster. An already initialised Ray (e.g. a test's cluster) is used as it is and left running."""
    import ray

    if ray.is_initialized():
        yield _info(ray, "existing")
        return
    if cpus < 1:
        raise ValueError(f"a local Ray needs at least 1 CPU, got {cpus}")
    common = {"include_dashboard": False, "logging_level": logging.WARNING, "runtime_env": {"env_vars": worker_env()}}
    if address is None:
        with local_ray_address():
            ray.init(address="local", num_cpus=cpus, object_store_memory=LOCAL_OBJECT_STORE_BYTES,
                     _node_ip_address=LOCAL_NODE_ADDRESS, **common)
        node_address = ray.util.get_node_ip_address()
        if node_address != LOCAL_NODE_ADDRESS:  # a Ray that ignores the address: never leave it listening outside
            ray.shutdown()
            raise RuntimeError(f"the local Ray took node address {node_address}, not {LOCAL_NODE_ADDRESS}: it would "
                               "listen on every interface (pg_learning.cluster.ray_session.local_ray_address)")
        where = "local"
    else:
        where = resolve_address(address)
        check_reachable(where)
        use_token_auth()
        ray.init(address=where, **common)
    try:
        yield _info(ray, where)
    finally:
        ray.shutdown()


@contextmanager
def local_ray_address() -> Iterator[None]:
    """Within the block, a Ray node started by ``ray.init`` keeps the loopback ``_node_ip_address`` it is given.

    Ray 2.60 on Linux replaces a loopback node address by the machine's routable one
    (``ray._private.services.resolve_ip_for_localhost``) unless ``ray_constants.ENABLE_RAY_CLUSTER`` is False: Ray's
    local-only mode, the default on macOS and Windows ($RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER), read when Ray is imported.
    The block sets it False and restores it. A node of address 127.0.0.1 starts its GCS server, raylet, workers and
    runtime-env agent on 127.0.0.1 (they bind the node address when it is loopback, else every interface)."""
    from ray._private import ray_constants

    saved = ray_constants.ENABLE_RAY_CLUSTER
    ray_constants.ENABLE_RAY_CLUSTER = False
    try:
        yield
    finally:
        ray_constants.ENABLE_RAY_CLUSTER = saved


def _info(ray, where: str) -> RayInfo:
    nodes = [n for n in ray.nodes() if n.get("Alive")]
    return RayInfo(where, len(nodes), int(ray.cluster_resources().get("CPU", 0)))
