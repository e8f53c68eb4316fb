"""The stack under test: `roslaunch -p PORT launch/sim.launch` with its own ROS master on a free loopback port, ROS
logs and home in the run's temporary folder, every process it starts carrying the run's marker (procs.MARKER_VAR) so
that all of them are found and stopped at the end, also after Ctrl-C or an exception."""

from __future__ import annotations

import http.client
import os
import signal
import socket
import subprocess
import time
import xml.etree.ElementTree as ET
import xmlrpc.client
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from . import procs

SERVICES = ("/pg/grasp_target", "/pg/infer", "/pg/execute_primitive", "/pg_sim/reset_scene")
NODES = ("pg_sim", "pg_policy", "heightmap_projector", "primitive_controller", "robot_state_publisher", "rosout")
CALLER = "/pg_reliability"


def free_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


class _Transport(xmlrpc.client.Transport):
    """XML-RPC with a socket timeout: a stopped process must not stall the suite."""

    def __init__(self, timeout_s: float) -> None:
        super().__init__()
        self.timeout_s = timeout_s

    def make_connection(self, host: Any) -> http.client.HTTPConnection:
        conn = super().make_connection(host)
        conn.timeout = self.timeout_s
        return conn


def master_proxy(uri: str, timeout_s: float = 3.0) -> xmlrpc.client.ServerProxy:
    return xmlrpc.client.ServerProxy(uri, transport=_Transport(timeout_s))


def scene_dir_args(launch_file: Path, scene_dir: Path) -> list[str]:
    """`name:=scene_dir` for a sim.launch argument that names the folders scene files may come from (any argument
    whose name speaks of allowed scene folders/paths/dirs), else nothing (the folder then travels as PG_SCENE_PATH)."""
    try:
        args = [(a.get("name", ""), a.get("default", "")) for a in ET.parse(launch_file).getroot().iter("arg")]
    except (OSError, ET.ParseError):
        return []
    for name, default in args:
        low = name.lower()
        if ("scene" in low or "allowed" in low) and any(k in low for k in ("dir", "folder", "path")):
            return [f"{name}:=[{scene_dir}]" if default.strip().startswith("[") else f"{name}:={scene_dir}"]
    return []


@dataclass
class StackConfig:
    repo: Path
    workdir: Path
    marker: str
    policy: str = "lite"
    scene: str = "packed/case01"
    scene_dir: Path | None = None
    startup_timeout_s: float = 240.0
    stop_timeout_s: float = 40.0


@dataclass
class Stack:
    """One ROS master + sim.launch. start() waits (bounded) for the services; stop() ends everything it started."""

    cfg: StackConfig
    port: int = field(default_factory=free_port)
    proc: subprocess.Popen | None = None
    extra: list[subprocess.Popen] = field(default_factory=list)
    starts: list[float] = field(default_factory=list)
    log_path: Path | None = None

    @property
    def uri(self) -> str:
        return f"http://127.0.0.1:{self.port}"

    def env(self) -> dict[str, str]:
        """Environment of every process the run starts: this one's, the private master, the run's marker."""
        env = dict(os.environ)
        env.update({"ROS_MASTER_URI": self.uri, "ROS_HOSTNAME": "localhost", "ROS_IP": "127.0.0.1",
                    "ROS_LOG_DIR": str(self.cfg.workdir / "ros_log"), "ROS_HOME": str(self.cfg.workdir / "ros_home"),
                    "PYTHONUNBUFFERED": "1", procs.MARKER_VAR: self.cfg.marker})
        if self.cfg.scene_dir is not None:
            env["PG_SCENE_PATH"] = os.pathsep.join(p for p in (str(self.cfg.scene_dir), env.get("PG_SCENE_PATH")) if p)
        return env

    def launch_args(self) -> list[str]:
        launch = self.cfg.repo / "launch" / "sim.launch"
        args = ["roslaunch", "-p", str(self.port), str(launch), f"policy:={self.cfg.policy}",
                f"scene:={self.cfg.scene}", "projector_required:=false"]
        if self.cfg.scene_dir is not None:
            args += scene_dir_args(launch, self.cfg.scene_dir)
        return args

    def start(self) -> float:
        """Launch and wait for the services; the start-up time (s). Raises RuntimeError (with the log's tail)."""
        self.cfg.workdir.mkdir(parents=True, exist_ok=True)
        self.log_path = self.cfg.workdir / f"launch_{len(self.starts)}.log"
        t0 = time.monotonic()
        with open(self.log_path, "wb") as log:
            self.proc = subprocess.Popen(self.launch_args(), cwd=self.cfg.repo, env=self.env(), stdout=log,
                                         stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL, start_new_session=True)
        deadline = t0 + self.cfg.startup_timeout_s
        while time.monotonic() < deadline:
            if self.proc.poll() is not None:
                raise RuntimeError(f"roslaunch exited with {self.proc.returncode} during start-up:\n{self.log_tail()}")
            if not self.missing_services():
                self.starts.append(time.monotonic() - t0)
                return self.starts[-1]
            time.sleep(0.5)
        raise RuntimeError(f"services {self.missing_services()} not up within {self.cfg.startup_timeout_s:.0f} s:\n"
                           f"{self.log_tail()}")

    def log_tail(self, chars: int = 3000) -> str:
        try:
            return self.log_path.read_text(errors="replace")[-chars:] if self.log_path else ""
        except OSError:
            return ""

    def missing_services(self) -> list[str]:
        try:
            master = master_proxy(self.uri)
            return [s for s in SERVICES if master.lookupService(CALLER, s)[0] != 1]
        except (OSError, xmlrpc.client.Error):
            return list(SERVICES)

    def node_pids(self) -> dict[str, int]:
        """Node name -> pid of the marked processes (nodes of this stack and the master)."""
        out: dict[str, int] = {}
        for p in procs.marked(self.cfg.marker):
            name = p.node_name
            if name and (name in NODES or name == "rosmaster"):
                out[name] = p.pid
        return out

    def healthy(self) -> tuple[bool, str]:
        """Launch running, every node alive and not stopped, every service registered."""
        if self.proc is None or self.proc.poll() is not None:
            return False, "roslaunch is not running"
        pids = self.node_pids()
        missing = [n for n in NODES if n not in pids]
        stopped = [n for n, pid in pids.items() if procs.state(pid) == "T"]
        services = self.missing_services()
        if missing or stopped or services:
            return False, f"missing nodes {missing}, stopped {stopped}, missing services {services}"
        return True, "ok"

    def spawn(self, args: list[str], **kw: Any) -> subprocess.Popen:
        """A process of the run (marked, own session), stopped with the stack."""
        kw.setdefault("env", self.env())
        kw.setdefault("cwd", self.cfg.repo)
        kw.setdefault("stdin", subprocess.DEVNULL)
        proc = subprocess.Popen(args, start_new_session=True, **kw)
        self.extra.append(proc)
        return proc

    def kill_node(self, name: str, timeout_s: float = 10.0) -> bool:
        """Ask a node to shut down through its XML-RPC API (as `rosnode kill`) on this stack's master."""
        try:
            code, _, uri = master_proxy(self.uri).lookupNode(CALLER, f"/{name}")
            if code != 1:
                return False
            master_proxy(uri, timeout_s).shutdown(CALLER, "killed by the reliability suite")
            return True
        except (OSError, xmlrpc.client.Error):
            return False

    def stop(self) -> dict[str, object]:
        """End everything this stack started; what had to be signalled after the launch's own shutdown."""
        for p in procs.marked(self.cfg.marker):  # a stopped process cannot shut down
            procs.send(p.pid, signal.SIGCONT)
        for proc in [*self.extra, *([self.proc] if self.proc else [])]:
            if proc.poll() is None:
                try:
                    os.killpg(proc.pid, signal.SIGINT)
                except (ProcessLookupError, PermissionError):
                    pass
        deadline = time.monotonic() + self.cfg.stop_timeout_s
        for proc in [*self.extra, *([self.proc] if self.proc else [])]:
            try:
                proc.wait(max(0.1, deadline - time.monotonic()))
            except subprocess.TimeoutExpired:
                pass
        signalled = procs.terminate_marked(self.cfg.marker)
        for proc in [*self.extra, *([self.proc] if self.proc else [])]:
            try:
                proc.wait(5.0)
            except subprocess.TimeoutExpired:
                pass
        self.extra.clear()
        return {"terminated_after_launch_shutdown": [f"{p.pid} {p.cmdline[:100]}" for p in signalled]}
