"""A local Ray (`ray_session` without an address, as `pushgrasp eval --workers N` starts it) listens on loopback only:
every TCP socket in LISTEN state held by this process or one it started (GCS server, raylet, workers, agents) is bound
to 127.0.0.1 or ::1, none to 0.0.0.0, :: or a routable address; and its processes end with the session. Processes
this test process had started before (another test's cluster) are not the local Ray's and are left out."""

from __future__ import annotations

import ipaddress
import os
import time
from pathlib import Path

from pg_learning.cluster.ray_session import LOCAL_NODE_ADDRESS, ray_session

LISTEN = "0A"  # TCP state LISTEN in /proc/net/tcp and tcp6


def _descendants(root: int) -> set[int]:
    """Pids of the processes below `root` (children, grandchildren, ...), from the parent pid in /proc/PID/stat."""
    parent: dict[int, int] = {}
    for stat in Path("/proc").glob("[0-9]*/stat"):
        try:
            text = stat.read_text()
        except OSError:  # ended meanwhile
            continue
        parent[int(stat.parent.name)] = int(text.rsplit(")", 1)[1].split()[1])  # the name may hold spaces
    found, frontier = set(), {root}
    while frontier:
        frontier = {pid for pid, ppid in parent.items() if ppid in frontier} - found
        found |= frontier
    return found


def _socket_inodes(pid: int) -> set[str]:
    inodes = set()
    try:
        for fd in Path(f"/proc/{pid}/fd").iterdir():
            try:
                target = os.readlink(fd)
            except OSError:
                continue
            if target.startswith("socket:["):
                inodes.add(target[len("socket:["):-1])
    except OSError:  # ended meanwhile
        pass
    return inodes


def _address(hex_addr: str) -> ipaddress.IPv4Address | ipaddress.IPv6Address:
    """The address of a /proc/net/tcp{,6} entry: 32-bit words in host (little-endian) byte order."""
    raw = bytes.fromhex(hex_addr)
    words = b"".join(raw[i:i + 4][::-1] for i in range(0, len(raw), 4))
    return ipaddress.ip_address(words)


def listening_sockets(pids: set[int]) -> list[tuple[int, str, int]]:
    """(pid, address, port) of every TCP socket in LISTEN state that one of `pids` holds."""
    owner = {inode: pid for pid in pids for inode in _socket_inodes(pid)}
    found = []
    for table in ("/proc/net/tcp", "/proc/net/tcp6"):
        for line in Path(table).read_text().splitlines()[1:]:
            fields = line.split()
            if len(fields) > 9 and fields[3] == LISTEN and fields[9] in owner:
                hex_addr, hex_port = fields[1].split(":")
                found.append((owner[fields[9]], str(_address(hex_addr)), int(hex_port, 16)))
    return found


def is_loopback(address: str) -> bool:
    ip = ipaddress.ip_address(address)
    mapped = ip.ipv4_mapped if isinstance(ip, ipaddress.IPv6Address) else None
    return (mapped or ip).is_loopback


def _name(pid: int) -> str:
    try:
        return Path(f"/proc/{pid}/comm").read_text().strip()
    except OSError:  # ended meanwhile
        return str(pid)


def test_a_local_ray_listens_on_loopback_only():
    me = os.getpid()
    before = _descendants(me)  # e.g. the session's two-node test cluster (conftest.ray_two_nodes): not this Ray's
    with ray_session(2) as info:
        import ray

        @ray.remote
        def node_address() -> str:  # a worker reaches the GCS and raylet on loopback
            return ray.util.get_node_ip_address()

        assert (info.address, info.cpus) == ("local", 2)
        assert ray.get(node_address.remote(), timeout=60) == LOCAL_NODE_ADDRESS
        started = _descendants(me) - before
        sockets = listening_sockets(started | {me})
        shown = [f"{_name(pid)} {addr if '.' in addr else f'[{addr}]'}:{port}" for pid, addr, port in sockets]
    assert any(pid != me for pid, _, _ in sockets), f"no Ray process listens: {shown}"
    outside = [s for s, (_, addr, _) in zip(shown, sockets, strict=True) if not is_loopback(addr)]
    assert not outside, f"a local Ray listens outside loopback: {outside} (all: {shown})"

    deadline = time.monotonic() + 20
    while (left := started & _descendants(me)) and time.monotonic() < deadline:
        time.sleep(0.5)
    assert not left, f"Ray processes left after the session: {sorted(left)}"
