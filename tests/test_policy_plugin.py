"""Third-party policies through the entry-point group `pushgrasp.policies` (docs/PLUGINS.md), end to end.

The example distribution tests/plugin_example (`pushgrasp-example-policy`, policy `example-centroid`) is installed
into the running interpreter's environment for this module, offline (`pip install --no-deps --no-build-isolation
--no-index` from a copy, so no build products land in the source tree), and uninstalled afterwards unless it was
installed before. Then: `pushgrasp policies` lists it, `pushgrasp eval --policy example-centroid` runs a trial, and
the policy node of `launch/sim.launch policy:=example-centroid` (its own ROS master on a free loopback port) answers
/pg/infer with the plugin's decision. The ROS part is skipped, with the reason, when the catkin devel space or
roslaunch is missing. A factory returning an object without the Policy protocol gives a clear TypeError.
"""

from __future__ import annotations

import importlib
import json
import math
import os
import shutil
import signal
import subprocess
import sys
import time
import uuid
import warnings
from collections.abc import Iterator
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest
from plugin_install import installed, pip, pushgrasp

REPO = Path(__file__).resolve().parents[1]
PLUGIN_SRC = REPO / "tests" / "plugin_example"
DIST = "pushgrasp-example-policy"
POLICY = "example-centroid"
TARGET = "pushgrasp_example_policy:CentroidGraspPolicy"
DEVEL = Path(os.environ.get("PG_DEVEL_DIR", REPO / "catkin_ws" / "devel"))
CLI_TIMEOUT_S = 120
EVAL_TIMEOUT_S = 900
STACK_TIMEOUT_S = 180.0  # wall seconds for the simulated stack to come up and answer /pg/infer
SHUTDOWN_TIMEOUT_S = 30.0
MARKER = "PG_PLUGIN_TEST_STACK"  # environment variable that tags every process of the test's ROS stack


@pytest.fixture(scope="module")
def example_plugin(tmp_path_factory: pytest.TempPathFactory) -> Iterator[str]:
    """Install the example plug-in (offline) for the module; uninstall it afterwards unless it was there before."""
    was_installed = installed(DIST)
    src = tmp_path_factory.mktemp("plugin") / "plugin_example"
    shutil.copytree(PLUGIN_SRC, src, ignore=shutil.ignore_patterns("build", "*.egg-info", "__pycache__"))
    res = pip("install", "--no-deps", "--no-build-isolation", "--no-index", "-q", str(src))
    try:
        assert res.returncode == 0, f"offline install of {PLUGIN_SRC} failed:\n{res.stdout}{res.stderr}"
        importlib.invalidate_caches()
        yield DIST
    finally:
        if not was_installed:
            out = pip("uninstall", "-y", "-q", DIST)
            assert out.returncode == 0, f"uninstalling {DIST} failed:\n{out.stdout}{out.stderr}"
            assert not installed(DIST), f"{DIST} is still installed"


# -- the registry ------------------------------------------------------------------------------------------------
def test_policies_lists_the_plugin_with_its_distribution(example_plugin: str) -> None:
    res = subprocess.run(pushgrasp("policies"), cwd=REPO, capture_output=True, text=True, timeout=CLI_TIMEOUT_S)
    assert res.returncode == 0, res.stdout + res.stderr
    rows = [line.split() for line in res.stdout.splitlines()]
    listed = [r for r in rows if r and r[0] == POLICY]
    assert listed, f"{POLICY} not listed:\n{res.stdout}"
    assert len(listed[0]) == 3 and listed[0][1].replace("_", "-").lower() == example_plugin, listed
    assert listed[0][2] == TARGET, listed


def test_make_policy_builds_the_plugin_and_it_decides(example_plugin: str) -> None:
    """In-process: the entry point resolves, and the policy grasps an oblong target across its narrow axis at its
    centroid, and pushes from beside a target too small to grasp."""
    from pg_core.geometry import load
    from pg_core.heightmap import Heightmap
    from pg_policy.policies.policy import Policy, PolicyOptions
    from pg_policy.policies.registry import make_policy, policies

    assert policies()[POLICY].target == TARGET
    geometry = load()
    policy = make_policy(POLICY, PolicyOptions(seed=5, geometry=geometry))
    assert isinstance(policy, Policy) and policy.name == POLICY
    policy.reset(7)
    h, w = geometry.heightmap.rows, geometry.heightmap.cols

    def observe(blocks: list[tuple[slice, slice, tuple[int, int, int]]]) -> SimpleNamespace:
        color = np.empty((h, w, 3), np.uint8)
        color[:] = (199, 178, 148)  # the table
        height = np.zeros((h, w), np.float32)
        for rows, cols, rgb in blocks:
            color[rows, cols], height[rows, cols] = rgb, 0.045
        hm = Heightmap(color, height, np.ones((h, w), bool), geometry.heightmap.resolution, geometry.workspace.bounds)
        return SimpleNamespace(heightmap=hm, target="green")

    green, blue = (89, 161, 79), (78, 121, 167)
    d = policy.act(observe([(slice(100, 120), slice(90, 140), green)]))  # 4 cm along y, 10 cm along x
    assert d.primitive == "grasp" and d.rotation == geometry.heightmap.rotations // 4, d  # closes along y
    assert abs(d.row - 109.5) <= 1 and abs(d.col - 114.5) <= 1, d
    assert math.isclose(d.yaw, math.pi / 2) and policy.q_maps() == {}
    d = policy.act(observe([(slice(100, 105), slice(100, 106), green), (slice(100, 120), slice(108, 130), blue)]))
    assert d.primitive == "push" and not (100 <= d.row < 105 and 100 <= d.col < 106), d  # starts beside it
    assert math.cos(d.yaw) < 0, d  # away from the blue neighbour on its +x side
    assert "push" in policy.last_note


class NotAPolicy:
    """A factory result without the Policy protocol (no reset, no q_maps)."""

    name = "not-a-policy"

    def __init__(self, opts: object) -> None:
        self.opts = opts

    def act(self, obs: object) -> None:
        return None


def test_a_factory_without_the_protocol_is_a_clear_type_error(monkeypatch: pytest.MonkeyPatch) -> None:
    from pg_policy.policies import registry

    known = registry.policies()
    entry = registry.PolicyEntry("broken", f"{__name__}:NotAPolicy", "broken-dist")
    monkeypatch.setattr(registry, "policies", lambda: {**known, "broken": entry})
    with pytest.raises(TypeError) as err:
        registry.make_policy("broken")
    text = str(err.value)
    assert "'broken'" in text and "broken-dist" in text and "NotAPolicy" in text, text
    assert "lacks the Policy protocol" in text and "PLUGINS.md" in text, text


# -- evaluation --------------------------------------------------------------------------------------------------
def test_eval_runs_the_plugin(example_plugin: str, tmp_path: Path) -> None:
    out = tmp_path / "eval"
    cmd = pushgrasp("eval", "--policy", POLICY, "--scenes", "packed/case01", "--trials", "1", "--out", str(out),
                     "--no-progress")
    env = dict(os.environ, OMP_NUM_THREADS="1", MPLBACKEND="Agg")
    res = subprocess.run(cmd, cwd=REPO, env=env, capture_output=True, text=True, timeout=EVAL_TIMEOUT_S)
    assert res.returncode == 0, f"{' '.join(cmd)} failed ({res.returncode}):\n{res.stdout[-4000:]}{res.stderr[-4000:]}"
    doc = json.loads((out / "results.json").read_text(encoding="utf-8"))
    assert doc["config"]["policy"] == POLICY and doc["config"]["policy_arg"] == POLICY, doc["config"]
    assert len(doc["trials"]) == 1, doc["trials"]
    trial = doc["trials"][0]
    assert trial["scene"] == "packed/case01" and trial["actions"], trial


# -- the policy node ---------------------------------------------------------------------------------------------
def _ros_environment() -> dict[str, str]:
    """The environment of `source scripts/ros_env.sh`; without ROS a "ROS tier:" skip (a failure unless
    PG_SKIP_ROS_TIER=1, conftest.py)."""
    if not (DEVEL / "setup.bash").exists():
        pytest.skip(f"ROS tier: no catkin devel space at {DEVEL} (make setup)")
    try:
        res = subprocess.run(["bash", "-c", f'source "{REPO}/scripts/ros_env.sh" >/dev/null && env -0'], cwd=REPO,
                             capture_output=True, timeout=60)
    except (OSError, subprocess.TimeoutExpired) as exc:
        pytest.skip(f"ROS tier: cannot source scripts/ros_env.sh: {exc}")
    if res.returncode != 0:
        pytest.skip(f"ROS tier: cannot source scripts/ros_env.sh: {res.stderr.decode(errors='replace').strip()}")
    env = dict(item.split("=", 1) for item in res.stdout.decode(errors="replace").split("\0") if "=" in item)
    if shutil.which("roslaunch", path=env.get("PATH")) is None:
        pytest.skip("ROS tier: roslaunch is not on PATH after sourcing scripts/ros_env.sh")
    return env


@pytest.fixture(scope="module")
def ros_env() -> dict[str, str]:
    """The ROS environment (requested before the plug-in, so that a skip installs nothing)."""
    return _ros_environment()


def _tagged(tag: str) -> list[int]:
    """Pids of this user's live processes whose environment holds MARKER=tag (the stack's processes)."""
    needle = f"{MARKER}={tag}\0".encode()
    pids = []
    for entry in Path("/proc").iterdir():
        if not entry.name.isdigit() or int(entry.name) == os.getpid():
            continue
        try:
            if needle in (entry / "environ").read_bytes():
                pids.append(int(entry.name))
        except OSError:  # gone, or not ours
            continue
    return pids


def _stop(proc: subprocess.Popen[bytes], tag: str) -> list[int]:
    """SIGINT to the launch's process group (roslaunch shuts its nodes and master down), SIGKILL to the group if it
    lingers, then SIGKILL to any process of the stack still alive; returns the pids that had to be killed so."""
    from pg_policy.ros.demo import stop

    stop(proc, SHUTDOWN_TIMEOUT_S)
    deadline = time.monotonic() + 10.0
    while _tagged(tag) and time.monotonic() < deadline:  # nodes finishing their own shutdown
        time.sleep(0.5)
    stragglers = _tagged(tag)
    for pid in stragglers:
        try:
            os.kill(pid, signal.SIGKILL)
        except ProcessLookupError:
            pass
    deadline = time.monotonic() + 10.0
    while _tagged(tag) and time.monotonic() < deadline:
        time.sleep(0.2)
    return stragglers


INFER_CLIENT = r"""
import json, sys, time
import rosgraph, rospy
from pg_msgs.srv import Infer
deadline = time.monotonic() + float(sys.argv[1])
while not rosgraph.Master("/pg_plugin_test").is_online():
    if time.monotonic() > deadline:
        sys.exit("no ROS master came up")
    time.sleep(0.3)
rospy.wait_for_service("/pg/infer", timeout=max(1.0, deadline - time.monotonic()))
call = rospy.ServiceProxy("/pg/infer", Infer)
while True:  # the first heightmap may still be on its way
    res = call(target="green")
    if res.success or time.monotonic() > deadline:
        break
    time.sleep(1.0)
d = res.decision
print(json.dumps({"success": res.success, "message": res.message, "policy": d.policy, "target": d.target,
                  "primitive": d.primitive, "rotation": d.rotation, "row": d.row, "col": d.col,
                  "position": [d.position.x, d.position.y, d.position.z], "target_pixels": d.target_pixels,
                  "frame": d.header.frame_id}))
"""


def test_policy_node_serves_the_plugin(ros_env: dict[str, str], example_plugin: str, tmp_path: Path) -> None:
    env = dict(ros_env)
    from pg_policy.ros.demo import free_port

    port, tag = free_port(), uuid.uuid4().hex
    env.pop("ROS_HOSTNAME", None)
    env.update(ROS_MASTER_URI=f"http://127.0.0.1:{port}", ROS_IP="127.0.0.1", ROS_LOG_DIR=str(tmp_path / "log"),
               ROS_HOME=str(tmp_path / "ros_home"), OMP_NUM_THREADS="1", **{MARKER: tag})
    launch_log = tmp_path / "roslaunch.log"
    cmd = ["roslaunch", "-p", str(port), str(REPO / "launch" / "sim.launch"), f"policy:={POLICY}",
           "scene:=packed/case01"]
    with open(launch_log, "wb") as log:
        proc = subprocess.Popen(cmd, cwd=REPO, env=env, stdout=log, stderr=subprocess.STDOUT, start_new_session=True)
    client: subprocess.Popen[str] | None = None
    stragglers: list[int] = []
    try:
        client = subprocess.Popen([sys.executable, "-c", INFER_CLIENT, str(STACK_TIMEOUT_S)], cwd=REPO, env=env,
                                  stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        deadline = time.monotonic() + STACK_TIMEOUT_S + 30.0
        while client.poll() is None and proc.poll() is None and time.monotonic() < deadline:
            time.sleep(0.5)
        if client.poll() is None:
            client.kill()
        out, err = client.communicate(timeout=30.0)
        tail = launch_log.read_text(errors="replace")[-6000:]
        assert proc.poll() is None, f"roslaunch ended early (exit {proc.returncode}):\n{tail}"
        assert client.returncode == 0, f"/pg/infer client failed ({client.returncode}):\n{err[-3000:]}\n{tail}"
        res = json.loads(out.strip().splitlines()[-1])
        assert res["success"], f"/pg/infer: {res['message']}\n{tail}"
        assert res["policy"] == POLICY and res["target"] == "green" and res["frame"] == "world", res
        assert res["primitive"] in (0, 1) and 0 <= res["rotation"] < 16 and res["target_pixels"] >= 25, res
        assert all(math.isfinite(v) for v in res["position"]), res
        assert abs(res["position"][0]) <= 0.224 and abs(res["position"][1]) <= 0.224, res
    finally:
        if client is not None and client.poll() is None:
            client.kill()
            client.wait(10.0)
        stragglers = _stop(proc, tag)
    left = _tagged(tag)
    assert not left, f"processes of the stack still running after shutdown: {left}"
    if stragglers:
        warnings.warn(f"stack processes outlived roslaunch's shutdown and were killed: {stragglers}", stacklevel=1)
