"""conftest.py's rule for skips: a test skips only for a labelled reason, and a "ROS tier:" skip fails unless the run
opts out with PG_SKIP_ROS_TIER=1 (README, "Tests")."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import textwrap
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]

TESTS = textwrap.dedent('''
    import pytest

    ros = pytest.importorskip("no_such_ros_module", reason="ROS tier: no_such_ros_module missing")


    def test_never_collected():
        pass
''')
OTHER = textwrap.dedent('''
    import pytest


    def test_unlabelled():
        pytest.skip("something is missing")


    def test_hardware():
        pytest.skip("opt-in: no CUDA device on this machine")


    @pytest.mark.skipif(True, reason="ROS tier: marker")
    def test_marker():
        pass


    def test_ros_fixture(ros_tier):
        assert ros_tier
''')


def _run(tmp_path: Path, opt_out: bool, *modules: str) -> tuple[int, str]:
    """(exit status, output) of pytest over the named test modules of this file, with the repository's conftest.py
    and without the ROS tier's prerequisites."""
    shutil.copy(REPO / "conftest.py", tmp_path / "conftest.py")
    for name in modules:
        (tmp_path / f"{name}.py").write_text(TESTS if name == "test_ros_module" else OTHER)
    env = {k: v for k, v in os.environ.items() if k != "PG_SKIP_ROS_TIER"}
    env["PG_DEVEL_DIR"] = str(tmp_path / "no_devel")
    if opt_out:
        env["PG_SKIP_ROS_TIER"] = "1"
    res = subprocess.run([sys.executable, "-m", "pytest", "-q", "-rA", "-p", "no:cacheprovider", "--rootdir",
                          str(tmp_path), "-c", os.devnull, *[f"{name}.py" for name in modules]], cwd=tmp_path, env=env,
                         capture_output=True, text=True, timeout=120)
    return res.returncode, res.stdout + res.stderr


def test_a_ros_module_that_cannot_import_fails_the_run(tmp_path: Path) -> None:
    code, out = _run(tmp_path, False, "test_ros_module")
    assert code != 0 and "ERROR test_ros_module.py" in out, out
    assert "ROS tier: no_such_ros_module missing" in out and "The ROS tier must run" in out


def test_ros_tier_and_unlabelled_skips_fail_hardware_skips_stay(tmp_path: Path) -> None:
    code, out = _run(tmp_path, False, "test_other")
    assert code == 1, out
    assert "FAILED test_other.py::test_unlabelled" in out and "unlabelled skip: something is missing" in out
    assert "test_other.py::test_marker" in out and "ROS tier: marker" in out and "The ROS tier must run" in out
    assert "test_other.py::test_ros_fixture" in out and "ROS tier: no catkin devel space" in out
    assert "SKIPPED [1] test_other.py" in out and "opt-in: no CUDA device" in out
    assert "1 skipped" in out


def test_the_opt_out_skips_only_the_ros_tier(tmp_path: Path) -> None:
    code, out = _run(tmp_path, True, "test_ros_module", "test_other")
    assert code == 1, out  # the unlabelled skip still fails
    assert "FAILED test_other.py::test_unlabelled" in out
    assert "ROS tier: no_such_ros_module missing" in out and "ROS tier: marker" in out
    assert "ROS tier: no catkin devel space" in out  # the fixture's check
    assert "1 failed" in out and "4 skipped" in out
