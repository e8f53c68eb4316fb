"""Loopback by default: with the environment of scripts/ros_env.sh (no ROS_HOSTNAME / ROS_IP / ROS_MASTER_URI of the
user's), a ROS master and its nodes listen on 127.0.0.1 only, and PG_ROS_NETWORK opts into a robot network.

The stack check starts `roscore` on a free port (rosmaster, roslaunch and rosout, a roscpp node) and a rospy node
with a publisher and a service, then reads the listening TCP sockets of those processes from /proc. The one
exception allowed is a roscpp node's XML-RPC port: xmlrpcpp binds INADDR_ANY whatever ROS_HOSTNAME says
(scripts/ros_env.sh says so); its topic and service ports must still be on loopback.
"""

from __future__ import annotations

import os
import signal
import socket
import subprocess
import sys
import time
import xmlrpc.client
from collections.abc import Iterator
from pathlib import Path
from urllib.parse import urlparse

import pytest

REPO = Path(__file__).resolve().parents[1]
NETWORK_VARS = ("ROS_HOSTNAME", "ROS_IP", "ROS_MASTER_URI", "PG_ROS_NETWORK", "PG_ROS_NET_SET")
LOOPBACK = ("127.", "::1", "::ffff:127.")

needs_devel = pytest.mark.usefixtures("ros_tier")  # the ROS tier (conftest.py): fails without it


def ros_env(**extra: str) -> dict[str, str]:
    """The environment `source scripts/ros_env.sh` gives a shell without network settings of its own (+ extra)."""
    env = {k: v for k, v in os.environ.items() if k not in NETWORK_VARS} | extra
    out = subprocess.run(["bash", "-c", f'source "{REPO}/scripts/ros_env.sh" >/dev/null && env -0'], env=env,
                         capture_output=True, text=True, check=True, timeout=60).stdout
    return dict(item.split("=", 1) for item in out.split("\0") if "=" in item)


@needs_devel
def test_default_is_loopback():
    env = ros_env()
    assert env.get("ROS_HOSTNAME") == "localhost" and "ROS_IP" not in env
    assert env["ROS_MASTER_URI"] == "http://localhost:11311"


@needs_devel
@pytest.mark.parametrize(("network", "var", "master"), [
    ("192.168.10.5", "ROS_IP", "http://192.168.10.5:11311"),
    ("robot-pc", "ROS_HOSTNAME", "http://robot-pc:11311"),
])
def test_robot_network_is_opt_in(network: str, var: str, master: str):
    env = ros_env(PG_ROS_NETWORK=network)
    assert env[var] == network and env["ROS_MASTER_URI"] == master
    assert ({"ROS_HOSTNAME", "ROS_IP"} - {var}).isdisjoint(env)


@needs_devel
def test_user_settings_are_kept():
    env = ros_env(ROS_IP="10.0.0.7", ROS_MASTER_URI="http://10.0.0.2:11311")
    assert env["ROS_IP"] == "10.0.0.7" and "ROS_HOSTNAME" not in env
    assert env["ROS_MASTER_URI"] == "http://10.0.0.2:11311"


def listening() -> dict[int, tuple[str, int]]:
    """{socket inode: (address, port)} of every TCP socket in LISTEN state (/proc/net/tcp, tcp6)."""
    out: dict[int, tuple[str, int]] = {}
    for name, family in (("tcp", socket.AF_INET), ("tcp6", socket.AF_INET6)):
        path = Path("/proc/net") / name
        if not path.exists():
            continue
        for line in path.read_text().splitlines()[1:]:
            fields = line.split()
            if fields[3] != "0A":
                continue
            hexaddr, hexport = fields[1].split(":")
            raw = bytes.fromhex(hexaddr)
            # /proc prints each 32-bit word in host (little-endian) order
            raw = b"".join(raw[i:i + 4][::-1] for i in range(0, len(raw), 4))
            out[int(fields[9])] = (socket.inet_ntop(family, raw), int(hexport, 16))
    return out


def sockets_of(pid: int, table: dict[int, tuple[str, int]]) -> list[tuple[str, int]]:
    found = []
    for fd in Path(f"/proc/{pid}/fd").iterdir():
        try:
            target = os.readlink(fd)
        except OSError:
            continue
        if target.startswith("socket:["):
            inode = int(target[8:-1])
            if inode in table:
                found.append(table[inode])
    return found


def descendants(pid: int) -> list[int]:
    children: dict[int, list[int]] = {}
    for d in Path("/proc").iterdir():
        if d.name.isdigit():
            try:
                ppid = int((d / "stat").read_text().rsplit(")", 1)[1].split()[1])
            except (OSError, IndexError, ValueError):
                continue
            children.setdefault(ppid, []).append(int(d.name))
    out, todo = [], [pid]
    while todo:
        p = todo.pop()
        out.append(p)
        todo.extend(children.get(p, []))
    return out


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


RSPY_NODE = """
import rospy
from std_msgs.msg import UInt32
from std_srvs.srv import Trigger, TriggerResponse
rospy.init_node("loopback_probe")
pub = rospy.Publisher("/loopback_probe/count", UInt32, queue_size=1, latch=True)
pub.publish(UInt32(1))
rospy.Service("/loopback_probe/ping", Trigger, lambda req: TriggerResponse(success=True))
print("ready", flush=True)
rospy.spin()
"""


@pytest.fixture
def stack(tmp_path: Path) -> Iterator[tuple[dict[str, str], list[subprocess.Popen]]]:
    port = free_port()
    env = ros_env(ROS_MASTER_URI=f"http://localhost:{port}") | {"ROS_LOG_DIR": str(tmp_path / "log"),
                                                               "ROS_HOME": str(tmp_path / "ros_home")}
    procs = [subprocess.Popen(["roscore", "-p", str(port)], env=env, stdout=subprocess.DEVNULL,
                              stderr=subprocess.STDOUT, start_new_session=True)]
    try:
        master = xmlrpc.client.ServerProxy(env["ROS_MASTER_URI"])
        deadline = time.monotonic() + 60
        while True:
            try:
                if master.lookupNode("/test", "/rosout")[0] == 1:
                    break
            except OSError:
                pass
            if time.monotonic() > deadline:
                pytest.fail("roscore did not start within 60 s")
            time.sleep(0.3)
        node = subprocess.Popen([sys.executable, "-c", RSPY_NODE], env=env, stdout=subprocess.PIPE, text=True,
                                start_new_session=True)
        procs.append(node)
        assert node.stdout is not None and node.stdout.readline().strip() == "ready"
        yield env, procs
    finally:
        for p in reversed(procs):
            if p.poll() is None:
                os.killpg(p.pid, signal.SIGINT)
        for p in reversed(procs):
            try:
                p.wait(timeout=20)
            except subprocess.TimeoutExpired:
                os.killpg(p.pid, signal.SIGKILL)
                p.wait(timeout=10)


@needs_devel
def test_master_and_nodes_listen_on_loopback(stack):
    env, procs = stack
    master = xmlrpc.client.ServerProxy(env["ROS_MASTER_URI"])
    xmlrpc_ports = {"/rosout": urlparse(master.lookupNode("/test", "/rosout")[2]).port}
    table = listening()
    seen, exposed = 0, []
    for pid in {p for proc in procs for p in descendants(proc.pid)}:
        try:
            cmd = Path(f"/proc/{pid}/cmdline").read_text().replace("\0", " ")
        except OSError:
            continue
        for addr, port in sockets_of(pid, table):
            seen += 1
            roscpp_xmlrpc = "rosout" in cmd and port == xmlrpc_ports["/rosout"] and addr in ("0.0.0.0", "::")
            if not addr.startswith(LOOPBACK) and not roscpp_xmlrpc:
                exposed.append(f"{Path(f'/proc/{pid}/comm').read_text().strip()} ({pid}): {addr}:{port}")
    # master, roslaunch, rosout (XML-RPC + TCPROS), the rospy node (XML-RPC + TCPROS)
    assert seen >= 5, f"only {seen} listening sockets found"
    assert not exposed, f"listening on other interfaces than loopback: {exposed}"
