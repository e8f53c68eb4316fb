"""The deployable runtime (pg_policy) runs on an install without the simulator: in child processes whose PYTHONPATH
starts with tests/without_sim (a sitecustomize.py whose sys.meta_path finder makes `import pybullet`, `import
pybullet_data`, `import pg_sim` and `import pg_learning` raise ModuleNotFoundError, as where they are not installed):

- every module of pg_policy, pg_core and pg_conversions imports (the ROS shell and the converters: ROS tier);
- `pushgrasp` runs its own subcommands, lists the learning and simulator ones as not installed, and those answer
  with the package they need and exit status 2;
- robot.launch's nodes (camera extrinsics, joint-state merger, heightmap projector, controller, the policy node with
  the shipped model) decide on the camera images of a recorded bag: tests/ros/robot_without_sim.launch under rostest,
  every Python process of the run under the blocker, none of them even attempting a blocked import.
"""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
BLOCKER = REPO / "tests" / "without_sim"
BLOCKED = ("pybullet", "pybullet_data", "pg_sim", "pg_learning")
ROS_MODULES = ("pg_policy.ros", "pg_conversions")  # need rospy and the built messages (the ROS tier)
ROSTEST_TIMEOUT_S = 1500


def blocked_env(log: Path | None = None) -> dict[str, str]:
    """This process's environment with the blocker first on PYTHONPATH (and its log file)."""
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join(p for p in (str(BLOCKER), env.get("PYTHONPATH")) if p)
    if log is not None:
        env["PG_WITHOUT_SIM_LOG"] = str(log)
    return env


def run_blocked(code: str, *args: str, timeout: float = 600) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-c", textwrap.dedent(code), *args], cwd=REPO, env=blocked_env(),
                          capture_output=True, text=True, timeout=timeout)


def pushgrasp(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "pg_policy.cli.main", *args], cwd=REPO, env=blocked_env(),
                          capture_output=True, text=True, timeout=600)


IMPORT_ALL = """
    import importlib, pkgutil, sys, traceback

    mode, blocked, ros_modules = sys.argv[1], sys.argv[2].split(","), tuple(sys.argv[3].split(","))
    for name in blocked:  # the blocker is in place
        try:
            importlib.import_module(name)
        except ImportError:
            continue
        sys.exit(f"{name} imported: the blocker is not in place")
    ros = mode == "ros"
    names = []
    for root in ("pg_core", "pg_conversions", "pg_policy"):
        pkg = importlib.import_module(root) if ros or root != "pg_conversions" else None
        if pkg is None:
            continue
        names.append(root)
        names += [m.name for m in pkgutil.walk_packages(pkg.__path__, root + ".")]
    names = [n for n in names if n.startswith(ros_modules) == ros]
    failed = []
    for name in names:
        try:
            importlib.import_module(name)
        except Exception:
            failed.append(name + ":\\n" + traceback.format_exc(limit=-3))
    for name in blocked:
        if name in sys.modules:
            failed.append(f"{name} in sys.modules")
    print(len(names), "modules:", " ".join(names))
    sys.exit("\\n".join(failed) if failed else 0)
"""


def test_every_runtime_module_imports_without_the_simulator():
    res = run_blocked(IMPORT_ALL, "core", ",".join(BLOCKED), ",".join(ROS_MODULES))
    assert res.returncode == 0, res.stdout + res.stderr
    names = res.stdout.split()
    assert "pg_policy.policies.learned" in names and "pg_policy.cli.main" in names and "pg_core.urdf_filter" in names
    assert not any(n.startswith(ROS_MODULES) for n in names)


@pytest.mark.usefixtures("ros_tier")
def test_the_ros_shell_and_the_converters_import_without_the_simulator():
    res = run_blocked(IMPORT_ALL, "ros", ",".join(BLOCKED), ",".join(ROS_MODULES))
    assert res.returncode == 0, res.stdout + res.stderr
    names = res.stdout.split()
    assert "pg_policy.ros.policy_node" in names and "pg_policy.ros.bag_replay" in names
    assert "pg_conversions.heightmap_msg" in names


def test_pushgrasp_runs_the_runtime_commands_and_names_the_package_the_others_need(tmp_path):
    res = pushgrasp("--help")
    assert res.returncode == 0, res.stderr
    for name in ("eval", "train", "infer", "bench", "compare", "kinds", "offline"):
        assert any(line.split()[:1] == [name] and "not installed: needs pg_learning" in line
                   for line in res.stdout.splitlines()), (name, res.stdout)
    assert "not installed: needs pg_sim" in res.stdout
    for args in (["eval", "--policy", "lite", "--scenes", "packed", "--trials", "1", "--out", str(tmp_path / "e")],
                 ["train", "--help"], ["infer", "-h"], ["offline", "pack", "x", "--out", "y"]):
        res = pushgrasp(*args)
        assert res.returncode == 2 and res.stdout == "", (args, res.stdout, res.stderr)
        assert res.stderr.strip() == (f"pushgrasp {args[0]}: error: this subcommand needs the learning package "
                                      "pg_learning (simulation: pg_sim, PyBullet), which is not installed here (no "
                                      "module 'pg_learning'); this install has the runtime (pg_policy) only")
    res = pushgrasp("scene", "list")
    assert res.returncode == 2 and "needs the simulator package pg_sim (PyBullet)" in res.stderr
    res = pushgrasp("policies")
    assert res.returncode == 0 and "lite" in res.stdout and "grasp_filter" in res.stdout, res.stderr
    for cmd in ("export", "replay"):
        res = pushgrasp(cmd, "--help")
        assert res.returncode == 0 and f"usage: pushgrasp {cmd}" in res.stdout, res.stderr
    assert not (tmp_path / "e").exists()


@pytest.mark.usefixtures("ros_tier")
def test_the_robot_runtime_decides_on_a_recorded_bag_without_the_simulator(tmp_path, monkeypatch):
    monkeypatch.syspath_prepend(str(REPO / "tests" / "ros"))
    from pg_rostest import write_robot_bag  # here, the simulator renders the recording

    bag = tmp_path / "robot_inputs.bag"
    write_robot_bag(bag)
    log = tmp_path / "without_sim.log"
    env = blocked_env(log)
    env.update(ROS_LOG_DIR=str(tmp_path / "log"), ROS_HOME=str(tmp_path / "ros_home"))
    launch = REPO / "tests" / "ros" / "robot_without_sim.launch"
    # ros_env.sh sets PYTHONPATH to the devel space: the blocker goes first again after it
    cmd = (f'source "{REPO}/scripts/ros_env.sh" && export PYTHONPATH="{BLOCKER}:$PYTHONPATH" && '
           f'rostest --text "{launch}" bag:="{bag}"')
    try:
        proc = subprocess.run(["bash", "-c", cmd], cwd=REPO, env=env, capture_output=True, text=True,
                              timeout=ROSTEST_TIMEOUT_S)
    except subprocess.TimeoutExpired as exc:
        pytest.fail(f"rostest robot_without_sim.launch ran past {ROSTEST_TIMEOUT_S} s\n{exc.stdout}")
    out = proc.stdout + proc.stderr
    assert proc.returncode == 0 and "RESULT: SUCCESS" in proc.stdout, out[-12000:]
    assert "Ran 2 tests" in out or "SUMMARY" in out, out[-4000:]
    lines = [line.split(maxsplit=2) + [""] for line in log.read_text(encoding="utf-8").splitlines()]
    loaded = [line[2] for line in lines if line[1] == "loaded"]
    for process in ("pg_policy/policy_node", "pg_policy/camera_calibration_publisher", "pg_policy/joint_state_merger",
                    "-m pg_core.urdf_filter", "rt_robot_without_sim.py", "rostest"):
        assert any(process in line for line in loaded), f"{process} did not run under the blocker:\n" + "\n".join(
            loaded)
    # only the test node's own check reached for a blocked module; no process of the runtime did
    reached = [" ".join(line) for line in lines if line[1] == "blocked" and "rt_robot_without_sim.py" not in line[2]]
    assert not reached, "\n".join(reached)
