"""Listening ports: every TCP port that a process of the stack listens on (master, node XML-RPC and TCPROS servers)
is bound to the loopback interface, since the stack runs on its own machine with ROS_HOSTNAME=localhost/ROS_IP=127.0.0.1
and nothing outside it needs to reach it. That includes a roscpp node's XML-RPC port, which xmlrpcpp binds to 0.0.0.0
whatever the environment says: scripts/ros_env.sh preloads the loopback bind shim (docs/RELIABILITY.md) in loopback
mode. A socket off loopback is reported with its node; an XML-RPC port among them (the master's URI for the node) is
counted apart, so a missing shim shows as such."""

from __future__ import annotations

from . import procs
from .report import ProbeResult
from .runner import Context

TITLE = "Listening ports"


def run(ctx: Context, res: ProbeResult) -> None:
    table = res.table("TCP ports in LISTEN state, per process of the stack", ["process", "pid", "address", "port"])
    exposed, xmlrpc = [], []
    count = 0
    uris = _node_ports(ctx)
    for p in sorted(procs.marked(ctx.stack.cfg.marker), key=lambda p: p.pid):
        name = p.node_name or ("roslaunch" if "roslaunch" in p.cmdline else p.cmdline.split(" ")[0].rsplit("/", 1)[-1])
        for host, port in procs.listening(p.pid):
            count += 1
            table.rows.append([name, p.pid, host, port])
            if not procs.loopback(host):
                (xmlrpc if uris.get(p.node_name or "") == int(port) else exposed).append(f"{name}:{host}:{port}")
    res.figures.update({"listening sockets": count, "not on loopback": len(exposed) + len(xmlrpc),
                        "of them roscpp XML-RPC ports (xmlrpcpp binds 0.0.0.0)": len(xmlrpc)})
    res.check("the stack listens on at least one port (the master)", count > 0, f"{count} sockets")
    off = exposed + xmlrpc
    res.check("every listening socket is bound to loopback, roscpp XML-RPC ports included", not off,
              f"{len(off)} on other interfaces: {', '.join(off[:8])}" if off else "all on 127.0.0.1/::1")


def _node_ports(ctx: Context) -> dict[str, int]:
    """{node name without the leading slash: port of its XML-RPC URI}, from the master; {} when it does not answer."""
    import xmlrpc.client
    from urllib.parse import urlparse

    from .stack import master_proxy

    try:
        master = master_proxy(ctx.stack.uri)
        _, _, state = master.getSystemState("/reliability")
        names = {n for group in state for _, nodes in group for n in nodes}
        ports = {}
        for n in names:
            code, _, uri = master.lookupNode("/reliability", n)
            if code == 1 and urlparse(uri).port:
                ports[n.lstrip("/")] = int(urlparse(uri).port)
        return ports
    except (OSError, xmlrpc.client.Error):
        return {}
