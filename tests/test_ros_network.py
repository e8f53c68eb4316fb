"""Loopback by default: with the environment of scripts/ros_env.sh (no ROS_HOSTNAME / ROS_IP / ROS_MASTER_URI of the
user's), a ROS master and its nodes listen on 127.0.0.1 only, and PG_ROS_NETWORK opts into a robot network.

The stack check starts `roscore` on a free port (rosmaster, roslaunch and rosout, a roscpp node) and a rospy node
with a publisher and a service, then reads the listening TCP sockets of those processes from /proc: none may be on
0.0.0.0, :: or any other address than loopback. That includes a roscpp node's XML-RPC port, which xmlrpcpp binds to
INADDR_ANY whatever ROS_HOSTNAME says; the loopback bind shim (pg_control's libpg_loopback_bind.so, preloaded by
scripts/ros_env.sh in loopback mode with PG_LOOPBACK_BIND=1) binds it to 127.0.0.1. The shim is also tested on its
own: a Python process binding 0.0.0.0 / :: with and without PG_LOOPBACK_BIND.
"""

from __future__ import annotations

import json
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
NETWORK_VARS = ("ROS_HOSTNAME", "ROS_IP", "ROS_MASTER_URI", "PG_ROS_NETWORK", "PG_ROS_NET_SET", "LD_PRELOAD",
                "PG_LOOPBACK_BIND")
LOOPBACK = ("127.", "::1", "::ffff:127.")
SHIM = "libpg_loopback_bind.so"  # in the devel space's lib/ (pg_control's pg_loopback_bind target)
OTHER_PRELOAD = "libm.so.6"  # a user's own LD_PRELOAD entry: any library ld.so finds by name

needs_devel = pytest.mark.usefixtures("ros_tier")  # the ROS tier (conftest.py): fails without it


def sourced(**extra: str) -> tuple[dict[str, str], str]:
    """The environment `source scripts/ros_env.sh` gives a shell without network settings or LD_PRELOAD of its own
    (+ extra), and what the script wrote to stderr."""
    env = {k: v for k, v in os.environ.items() if k not in NETWORK_VARS} | extra
    proc = subprocess.run(["bash", "-c", f'source "{REPO}/scripts/ros_env.sh" >/dev/null && env -0'], env=env,
                          capture_output=True, text=True, check=True, timeout=60)
    return dict(item.split("=", 1) for item in proc.stdout.split("\0") if "=" in item), proc.stderr


def ros_env(**extra: str) -> dict[str, str]:
    return sourced(**extra)[0]


def shim_of(devel: Path) -> Path:
    shim = devel / "lib" / SHIM
    assert shim.is_file(), f"{shim} not built: run scripts/catkin_build.sh"
    return shim


def test_default_is_loopback(ros_tier: Path):
    env = ros_env()
    assert env.get("ROS_HOSTNAME") == "localhost" and "ROS_IP" not in env
    assert env["ROS_MASTER_URI"] == "http://localhost:11311"
    assert env.get("PG_LOOPBACK_BIND") == "1" and env.get("LD_PRELOAD") == str(shim_of(ros_tier))


def test_loopback_keeps_the_users_preload_and_sourcing_twice_adds_one_shim(ros_tier: Path):
    shim = str(shim_of(ros_tier))
    env = ros_env(LD_PRELOAD=OTHER_PRELOAD)
    assert env["LD_PRELOAD"] == f"{shim}:{OTHER_PRELOAD}" and env["PG_LOOPBACK_BIND"] == "1"
    again = ros_env(**{k: env[k] for k in NETWORK_VARS if k in env})
    assert again["LD_PRELOAD"] == env["LD_PRELOAD"] and again["PG_LOOPBACK_BIND"] == "1"


def test_without_a_built_shim_nothing_is_preloaded(ros_tier: Path, tmp_path: Path):
    (tmp_path / "setup.bash").write_text(f'source "{ros_tier}/setup.bash"\n')  # a devel space with no lib/
    env, stderr = sourced(PG_DEVEL_DIR=str(tmp_path))
    assert env.get("ROS_HOSTNAME") == "localhost"
    assert "LD_PRELOAD" not in env and "PG_LOOPBACK_BIND" not in env
    assert stderr == ""


@needs_devel
@pytest.mark.parametrize(("network", "var", "master"), [
    ("192.168.10.5", "ROS_IP", "http://192.168.10.5:11311"),
    ("robot-pc", "ROS_HOSTNAME", "http://robot-pc:11311"),
])
def test_robot_network_is_opt_in(network: str, var: str, master: str, ros_tier: Path):
    # as an earlier sourcing in loopback mode left the shell: the shim goes, the user's own entry stays
    env = ros_env(PG_ROS_NETWORK=network, LD_PRELOAD=f"{shim_of(ros_tier)}:{OTHER_PRELOAD}", PG_LOOPBACK_BIND="1")
    assert env[var] == network and env["ROS_MASTER_URI"] == master
    assert ({"ROS_HOSTNAME", "ROS_IP"} - {var}).isdisjoint(env)
    assert env.get("LD_PRELOAD") == OTHER_PRELOAD and "PG_LOOPBACK_BIND" not in env


@needs_devel
def test_user_settings_are_kept():
    env = ros_env(ROS_IP="10.0.0.7", ROS_MASTER_URI="http://10.0.0.2:11311")
    assert env["ROS_IP"] == "10.0.0.7" and "ROS_HOSTNAME" not in env
    assert env["ROS_MASTER_URI"] == "http://10.0.0.2:11311"
    assert "LD_PRELOAD" not in env and "PG_LOOPBACK_BIND" not in env


BIND_PROBE = """
import json, socket
out = {}
for family, wildcard, kind in ((socket.AF_INET, "0.0.0.0", "tcp"), (socket.AF_INET, "0.0.0.0", "udp"),
                               (socket.AF_INET6, "::", "tcp"), (socket.AF_INET6, "::", "udp"),
                               (socket.AF_INET, "127.0.0.2", "tcp")):
    with socket.socket(family, socket.SOCK_STREAM if kind == "tcp" else socket.SOCK_DGRAM) as s:
        try:
            s.bind((wildcard, 0))
        except OSError:  # no IPv6 here
            continue
        out[f"{wildcard} {kind}"] = s.getsockname()[0]
import ctypes, ctypes.util
xmlrpc = ctypes.CDLL(ctypes.util.find_library("xmlrpcpp") or "libxmlrpcpp.so")
xmlrpc_bind = xmlrpc._ZN6XmlRpc12XmlRpcSocket4bindEii  # static bool XmlRpc::XmlRpcSocket::bind(int fd, int port)
xmlrpc_bind.argtypes, xmlrpc_bind.restype = (ctypes.c_int, ctypes.c_int), ctypes.c_bool
with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
    if xmlrpc_bind(s.fileno(), 0):  # what a roscpp node's XML-RPC server does: INADDR_ANY
        out["xmlrpcpp tcp"] = s.getsockname()[0]
print(json.dumps(out))
"""


def bound(env: dict[str, str]) -> dict[str, str]:
    """{"<address asked> <tcp|udp>": address bound} of BIND_PROBE run with env."""
    out = subprocess.run([sys.executable, "-c", BIND_PROBE], env=env, capture_output=True, text=True, check=True,
                         timeout=60).stdout
    return json.loads(out)


@pytest.mark.parametrize("setting", ["1", "0", None])
def test_shim_moves_xmlrpcpp_wildcard_binds_to_loopback_only_when_enabled(setting: str | None, ros_tier: Path):
    env = {k: v for k, v in os.environ.items() if k not in ("LD_PRELOAD", "PG_LOOPBACK_BIND")}
    env["LD_PRELOAD"] = str(shim_of(ros_tier))
    if setting is not None:
        env["PG_LOOPBACK_BIND"] = setting
    got = bound(env)
    assert "0.0.0.0 tcp" in got and "0.0.0.0 udp" in got and "xmlrpcpp tcp" in got
    # binds of every other library (here Python's) are as asked, whatever the setting
    want = {f"{a} {k}": a for a in ("0.0.0.0", "::") for k in ("tcp", "udp")}
    want["127.0.0.2 tcp"] = "127.0.0.2"  # a specific address is bound as asked
    # xmlrpcpp's wildcard bind moves to loopback only when the shim is enabled
    want["xmlrpcpp tcp"] = "127.0.0.1" if setting == "1" else "0.0.0.0"
    assert got == {k: v for k, v in want.items() if k in got}


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
    """No listening socket of the stack on 0.0.0.0, :: or another non-loopback address, roscpp's XML-RPC included."""
    env, procs = stack
    master = xmlrpc.client.ServerProxy(env["ROS_MASTER_URI"])
    rosout_xmlrpc = urlparse(master.lookupNode("/test", "/rosout")[2]).port  # xmlrpcpp's INADDR_ANY bind
    table = listening()
    seen, exposed = [], []
    for pid in {p for proc in procs for p in descendants(proc.pid)}:
        try:
            found = sockets_of(pid, table)
        except OSError:
            continue
        seen += found
        exposed += [f"{Path(f'/proc/{pid}/comm').read_text().strip()} ({pid}): {addr}:{port}"
                    for addr, port in found if not addr.startswith(LOOPBACK)]
    # master, roslaunch, rosout (XML-RPC + TCPROS), the rospy node (XML-RPC + TCPROS)
    assert len(seen) >= 5, f"only {len(seen)} listening sockets found"
    assert not exposed, f"listening on other interfaces than loopback: {exposed}"
    assert ("127.0.0.1", rosout_xmlrpc) in seen, f"rosout's XML-RPC port {rosout_xmlrpc} not found: {seen}"
