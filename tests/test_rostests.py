"""Integration tier: every rostest launch file of the project, each against its own ROS master (random port).

Discovered files: catkin_ws/src/<pkg>/test/*.test and tests/ros/*.test. Each runs as
`source scripts/ros_env.sh && rostest --text FILE` (devel space sourced, the venv's Python first on PATH), bounded
by ROSTEST_TIMEOUT_S. Test nodes named in those files are unittest scripts called rt_*.py (so that pytest itself
does not collect them). Without the devel space or ROS's tools: a "ROS tier:" skip, which fails unless
PG_SKIP_ROS_TIER=1 (conftest.py).
"""

from __future__ import annotations

import os
import subprocess
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
ROSTEST_TIMEOUT_S = 1500
TEST_FILES = sorted((REPO / "catkin_ws" / "src").glob("*/test/*.test")) + sorted(
    (REPO / "tests" / "ros").glob("*.test"))


@pytest.mark.usefixtures("ros_tier")
@pytest.mark.parametrize("test_file", TEST_FILES, ids=[f"{f.parent.parent.name}/{f.name}" for f in TEST_FILES])
def test_rostest(test_file: Path, tmp_path: Path) -> None:
    env = dict(os.environ, ROS_LOG_DIR=str(tmp_path / "log"), ROS_HOME=str(tmp_path / "ros_home"))
    cmd = f'source "{REPO}/scripts/ros_env.sh" && rostest --text "{test_file}"'
    try:
        proc = subprocess.run(["bash", "-c", cmd], cwd=REPO, env=env, capture_output=True, text=True,
                              timeout=ROSTEST_TIMEOUT_S)
    except subprocess.TimeoutExpired as exc:
        out = (exc.stdout or b"")[-6000:] if isinstance(exc.stdout, bytes) else (exc.stdout or "")[-6000:]
        pytest.fail(f"rostest {test_file.name} ran past {ROSTEST_TIMEOUT_S} s\n{out}")
    out = proc.stdout + proc.stderr
    ok = proc.returncode == 0 and "RESULT: SUCCESS" in proc.stdout
    assert ok, f"rostest {test_file.name} failed (exit {proc.returncode}):\n{out[-12000:]}"
