"""Processes from /proc (Linux): the ones a run started (found by a marker in their environment), their resident
memory, their state and the TCP ports they listen on. Only ever signals processes that carry the run's marker."""

from __future__ import annotations

import os
import signal
import time
from dataclasses import dataclass
from pathlib import Path

MARKER_VAR = "PG_RELIABILITY_RUN"


@dataclass(frozen=True)
class Proc:
    pid: int
    cmdline: str

    @property
    def node_name(self) -> str | None:
        """The ROS node name of a node process (its `__name:=` argument), "rosmaster" for the master."""
        for arg in self.cmdline.split(" "):
            if arg.startswith("__name:="):
                return arg.split(":=", 1)[1]
        return "rosmaster" if "rosmaster" in self.cmdline else None


def _read(path: str) -> bytes:
    try:
        with open(path, "rb") as f:
            return f.read()
    except OSError:
        return b""


def cmdline(pid: int) -> str:
    return _read(f"/proc/{pid}/cmdline").replace(b"\0", b" ").decode(errors="replace").strip()


def state(pid: int) -> str:
    """One-letter state (R, S, T stopped, Z zombie, ...) or "" when gone."""
    stat = _read(f"/proc/{pid}/stat").decode(errors="replace")
    return stat.rsplit(")", 1)[1].split()[0] if ")" in stat else ""


def alive(pid: int) -> bool:
    return state(pid) not in ("", "Z", "X")


def rss_mb(pid: int) -> float | None:
    for line in _read(f"/proc/{pid}/status").decode(errors="replace").splitlines():
        if line.startswith("VmRSS:"):
            return int(line.split()[1]) / 1024.0
    return None


def marked(marker: str) -> list[Proc]:
    """Live processes (zombies excluded) whose environment carries MARKER_VAR=marker, other than this one."""
    tag = f"{MARKER_VAR}={marker}".encode()
    me = os.getpid()
    found = []
    for entry in os.listdir("/proc"):
        if not entry.isdigit() or int(entry) == me:
            continue
        pid = int(entry)
        if tag in _read(f"/proc/{pid}/environ").split(b"\0") and alive(pid):
            found.append(Proc(pid, cmdline(pid)))
    return found


def send(pid: int, sig: signal.Signals) -> bool:
    try:
        os.kill(pid, sig)
        return True
    except ProcessLookupError:
        return False


def terminate_marked(marker: str, grace_s: float = 5.0) -> list[Proc]:
    """SIGCONT then SIGTERM every marked process, SIGKILL what is left after grace_s; the processes that had to be
    signalled (empty when nothing was left)."""
    procs = marked(marker)
    for p in procs:
        send(p.pid, signal.SIGCONT)
        send(p.pid, signal.SIGTERM)
    deadline = time.monotonic() + grace_s
    while time.monotonic() < deadline and any(alive(p.pid) for p in procs):
        time.sleep(0.1)
    for p in procs:
        if alive(p.pid):
            send(p.pid, signal.SIGKILL)
    deadline = time.monotonic() + 3.0
    while time.monotonic() < deadline and any(alive(p.pid) for p in procs):
        time.sleep(0.1)
    return procs


def _socket_inodes(pid: int) -> set[str]:
    inodes = set()
    fd_dir = Path(f"/proc/{pid}/fd")
    try:
        for fd in fd_dir.iterdir():
            try:
                target = os.readlink(fd)
            except OSError:
                continue
            if target.startswith("socket:["):
                inodes.add(target[8:-1])
    except OSError:
        pass
    return inodes


def _hex_addr(text: str) -> tuple[str, int]:
    addr, port = text.split(":")
    raw = bytes.fromhex(addr)
    if len(raw) == 4:
        host = ".".join(str(b) for b in raw[::-1])
    else:  # IPv6: four little-endian 32-bit words
        words = [raw[i:i + 4][::-1] for i in range(0, 16, 4)]
        flat = b"".join(words)
        host = ":".join(flat[i:i + 2].hex() for i in range(0, 16, 2))
        if host == ":".join(["0000"] * 8):
            host = "::"
        elif host == ":".join(["0000"] * 7 + ["0001"]):
            host = "::1"
    return host, int(port, 16)


def listening(pid: int) -> list[tuple[str, int]]:
    """(address, port) of every TCP socket in LISTEN state that the process holds."""
    inodes = _socket_inodes(pid)
    out = []
    for table in ("/proc/net/tcp", "/proc/net/tcp6"):
        for line in _read(table).decode(errors="replace").splitlines()[1:]:
            parts = line.split()
            if len(parts) > 9 and parts[3] == "0A" and parts[9] in inodes:
                out.append(_hex_addr(parts[1]))
    return sorted(set(out))


def loopback(host: str) -> bool:
    return host.startswith("127.") or host == "::1" or host.endswith("ffff:7f00:0001")
