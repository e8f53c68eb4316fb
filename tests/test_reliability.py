"""Short form of the fault suite: `scripts/reliability.py --quick` (the probes of tests/reliability with small counts,
against its own sim.launch on a private ROS master, a few minutes on two cores), run once; then one test per probe
asserting that each of its invariants held, and one that nothing the suite started was left running.

The long form, with its report: `scripts/reliability.py --out DIR --soak-calls 200 --fuzz 500` (`--help`).
Without the ROS tier (conftest.py): a "ROS tier:" skip, which fails unless PG_SKIP_ROS_TIER=1.
"""

from __future__ import annotations

import json
import subprocess
from pathlib import Path
from typing import Any

import pytest
from reliability.options import PROBES

REPO = Path(__file__).resolve().parents[1]
SCRIPT = REPO / "scripts" / "reliability.py"
RUN_TIMEOUT_S = 840  # the short form takes 2-4 minutes on two cores

pytestmark = [pytest.mark.timeout(RUN_TIMEOUT_S + 60), pytest.mark.usefixtures("ros_tier")]


@pytest.fixture(scope="module")
def quick_report(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Any]:
    out = tmp_path_factory.mktemp("reliability")
    cmd = f'source "{REPO}/scripts/ros_env.sh" && exec python "{SCRIPT}" --quick --seed 1 --out "{out}"'
    try:
        proc = subprocess.run(["bash", "-c", cmd], cwd=REPO, capture_output=True, text=True, timeout=RUN_TIMEOUT_S)
    except subprocess.TimeoutExpired as exc:
        tail = exc.stderr[-4000:] if isinstance(exc.stderr, str) else ""
        pytest.fail(f"scripts/reliability.py --quick ran past {RUN_TIMEOUT_S} s\n{tail}")
    report = out / "report.json"
    assert report.is_file(), f"no report (exit {proc.returncode}):\n{(proc.stdout + proc.stderr)[-6000:]}"
    return json.loads(report.read_text())


def _probe(report: dict[str, Any], name: str) -> dict[str, Any]:
    found = [p for p in report["probes"] if p["name"] == name]
    assert found, f"probe {name} did not run; ran: {[p['name'] for p in report['probes']]}"
    return found[0]


@pytest.mark.parametrize("name", PROBES)
def test_probe_invariants(quick_report: dict[str, Any], name: str) -> None:
    probe = _probe(quick_report, name)
    assert probe["error"] is None, f"{name}: the probe itself failed: {probe['error']}\n{probe['notes']}"
    failed = [f"{c['name']}: {c['detail']}" for c in probe["checks"] if not c["passed"]]
    assert probe["checks"], f"{name}: no invariant was checked"
    assert not failed, f"{name}: {len(failed)} invariant(s) broken:\n  " + "\n  ".join(failed)


def test_nothing_left_running(quick_report: dict[str, Any]) -> None:
    cleanup = quick_report["cleanup"]
    assert cleanup["passed"], f"left running after the suite: {cleanup['left_running']}"
