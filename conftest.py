"""What a test run may leave out, for every test of the repository (pytest loads this file for all of them).

A test skips only for a reason it labels, at the start of the skip message:
- "ROS tier: ..." -- the ROS tier cannot run here (no catkin devel space, roscore / rostest / roslaunch missing, pg_msgs
  or the C++ tools not built). That is a FAILURE, unless the run opts out of the tier with PG_SKIP_ROS_TIER=1
  (README, "Tests"; `make test` and CI never set it).
- "opt-in: ..." -- a hardware test whose hardware (a CUDA device) this machine lacks (DESIGN.md section 9: hardware
  tests are opt-in).
- "reference data: ..." -- a test of the paper authors' reference cases in ../shared/reference, absent here.
Any other skip fails as an unlabelled skip, so no tier can hide behind a skip.

The fixture `ros_tier` checks the ROS tier's prerequisites: tests that need it request it (or
`pytest.mark.usefixtures("ros_tier")`).
"""

from __future__ import annotations

import os
import shutil
from pathlib import Path

import pytest

from pg_core.cpu_kernels import pin_cpu_kernels

pin_cpu_kernels()  # before any test loads numpy: the kernels the CLI and the nodes run (pg_core.cpu_kernels)

REPO = Path(__file__).resolve().parent
ROS_TIER_OPT_OUT = "PG_SKIP_ROS_TIER"
ROS_TIER = "ROS tier: "
ALWAYS_ALLOWED = ("opt-in: ", "reference data: ")
ROS_TOOLS = ("roscore", "rostest", "roslaunch")


def skip_verdict(reason: str, env: dict[str, str] | None = None) -> str | None:
    """None when a skip with this reason may stand, else the message of the failure it becomes."""
    env = os.environ if env is None else env
    if reason.startswith(ALWAYS_ALLOWED):
        return None
    if reason.startswith(ROS_TIER):
        if env.get(ROS_TIER_OPT_OUT) == "1":
            return None
        return (f"{reason}\nThe ROS tier must run: `make setup` builds it (then `source scripts/ros_env.sh`); to leave "
                f"it out knowingly, set {ROS_TIER_OPT_OUT}=1 (conftest.py, README \"Tests\").")
    return (f"unlabelled skip: {reason}\nA test may skip only for a labelled reason ({ROS_TIER.strip()}, "
            f"{', '.join(a.strip() for a in ALWAYS_ALLOWED)}; conftest.py); fix what is missing instead.")


def _skip_reason(longrepr: object) -> str:
    """The message of a skip report ((path, line, "Skipped: message") or a plain text)."""
    text = str(longrepr[2]) if isinstance(longrepr, tuple) and len(longrepr) == 3 else str(longrepr)
    return text.removeprefix("Skipped: ")


def _judge(report: pytest.BaseReport) -> None:
    if report.skipped and not hasattr(report, "wasxfail"):
        message = skip_verdict(_skip_reason(report.longrepr))
        if message is not None:
            report.outcome = "failed"
            report.longrepr = message


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_makereport(item: pytest.Item, call: pytest.CallInfo) -> object:
    outcome = yield
    _judge(outcome.get_result())


@pytest.hookimpl(hookwrapper=True)
def pytest_make_collect_report(collector: pytest.Collector) -> object:
    outcome = yield
    _judge(outcome.get_result())


def devel_dir() -> Path:
    """The catkin devel space the ROS tier uses ($PG_DEVEL_DIR, else catkin_ws/devel)."""
    return Path(os.environ.get("PG_DEVEL_DIR", REPO / "catkin_ws" / "devel"))


def ros_tier_missing() -> str | None:
    """Why the ROS tier cannot run here (None when it can): the devel space and ROS's command-line tools."""
    devel = devel_dir()
    if not (devel / "setup.bash").is_file():
        return f"no catkin devel space at {devel} (make setup, or set PG_DEVEL_DIR)"
    missing = [tool for tool in ROS_TOOLS if shutil.which(tool) is None]
    if missing:
        return f"{', '.join(missing)} not on PATH (make setup installs ROS; source scripts/ros_env.sh)"
    return None


@pytest.fixture(scope="session")
def ros_tier() -> Path:
    """The catkin devel space, once the ROS tier's prerequisites are there; otherwise a "ROS tier:" skip (a failure
    unless PG_SKIP_ROS_TIER=1)."""
    why = ros_tier_missing()
    if why is not None:
        pytest.skip(ROS_TIER + why)
    return devel_dir()
