"""Cross-language kinematics: pg_control's C++ (KDL on the URDF) against pg_sim's Python (closed-form DH).

Sim and controller must never disagree about the robot (DESIGN.md section 3): the C++ forward kinematics must equal
pg_core.kinematics.tcp_fk / tool_fk, and the C++ IK (KDL, restricted to the config's ik_branch, nearest the seed)
must
pick the same joint configuration as pg_sim.robot.ik.IkSolver for the tool-down poses the primitives use. The C++ side
runs
through the `pg_control_kinematics` command-line tool of the catkin build (skipped when it is not built).
"""

from __future__ import annotations

import math
import os
import subprocess
from pathlib import Path

import numpy as np
import pytest

from pg_core.geometry import DEFAULT_CONFIG, load
from pg_core.kinematics import arm_base_pose, tcp_fk, tool_fk
from pg_core.ur_ik import ik_all
from pg_sim.robot.ik import IkSolver

REPO = Path(__file__).resolve().parents[4]
DEVEL = Path(os.environ.get("PG_DEVEL_DIR", REPO / "catkin_ws" / "devel"))
CLI = DEVEL / "lib" / "pg_control" / "pg_control_kinematics"

pytestmark = pytest.mark.skipif(not CLI.exists(), reason=f"ROS tier: {CLI} not built (make setup, or set PG_DEVEL_DIR)")


def _run(lines: list[str]) -> list[str]:
    """Answers of the C++ tool, one per command line."""
    proc = subprocess.run([str(CLI), str(DEFAULT_CONFIG)], input="\n".join(lines) + "\n", capture_output=True,
                          text=True, timeout=120, check=True)
    out = proc.stdout.splitlines()
    assert len(out) == len(lines), proc.stderr
    assert not any(o.startswith("error") for o in out), [o for o in out if o.startswith("error")][:3]
    return out


def _fmt(values) -> str:
    return " ".join(repr(float(v)) for v in values)


@pytest.fixture(scope="module")
def geometry():
    return load(DEFAULT_CONFIG)


@pytest.mark.parametrize("arm", ["left", "right"])
def test_fk_matches_python(geometry, arm):
    rng = np.random.default_rng(5)
    qs = rng.uniform(-2 * math.pi, 2 * math.pi, size=(200, 6))
    out = _run([f"fk {arm} {_fmt(q)}" for q in qs] + [f"tool0 {arm} {_fmt(q)}" for q in qs])
    for i, q in enumerate(qs):
        tcp = np.array(out[i].split(), dtype=float).reshape(4, 4)
        tool0 = np.array(out[len(qs) + i].split(), dtype=float).reshape(4, 4)
        np.testing.assert_allclose(tcp, tcp_fk(geometry, arm, q), atol=1e-9)
        np.testing.assert_allclose(tool0, tool_fk(geometry, arm, q), atol=1e-9)


@pytest.mark.parametrize("arm", ["left", "right"])
def test_ik_picks_the_same_configuration_as_python(geometry, arm):
    """Tool-down poses over the workspace, seeded from home and from a neighbouring solution (as along a line)."""
    rng = np.random.default_rng(9)
    ik = IkSolver(geometry)
    home = np.array(geometry.robot.arms[arm].home)
    cases = []
    for _ in range(150):
        pos = np.array([rng.uniform(-0.224, 0.224), rng.uniform(-0.224, 0.224), rng.uniform(0.005, 0.4)])
        yaw = rng.uniform(-math.pi, math.pi)
        seed = home
        q_home = ik.solve(arm, pos, yaw, home)
        assert q_home is not None
        cases.append((pos, yaw, seed, q_home))
        near = pos + rng.uniform(-0.01, 0.01, size=3)  # the next waypoint of a line, seeded from this one
        q_near = ik.solve(arm, near, yaw, q_home)
        assert q_near is not None
        cases.append((near, yaw, q_home, q_near))
    out = _run([f"ik {arm} {_fmt(pos)} {yaw!r} {_fmt(seed)}" for pos, yaw, seed, _ in cases])
    worst = 0.0
    for (pos, yaw, seed, q_py), line in zip(cases, out, strict=True):
        assert line != "none", f"C++ IK failed at {pos} yaw {yaw} (Python: {q_py})"
        q_cpp = np.array(line.split(), dtype=float)
        worst = max(worst, float(np.abs(q_cpp - q_py).max()))
        np.testing.assert_allclose(q_cpp, q_py, atol=1e-5, err_msg=f"pose {pos} yaw {yaw} seed {seed}")
    assert worst < 1e-5


@pytest.mark.parametrize("arm", ["left", "right"])
def test_branch_signs_match_ur_ik(geometry, arm):
    """The C++ branch of a random configuration is the ur_ik branch whose closed-form solution is that configuration."""
    r = geometry.robot
    rng = np.random.default_rng(13)
    qs = rng.uniform(-math.pi, math.pi, size=(200, 6))
    qs = qs[(np.abs(np.sin(qs[:, 2])) > 0.05) & (np.abs(np.sin(qs[:, 4])) > 0.05)]  # away from branch boundaries
    out = _run([f"branch {arm} {_fmt(q)}" for q in qs])
    for q, line in zip(qs, out, strict=True):
        branch = tuple(int(v) for v in line.split())
        base_t_tool0 = np.linalg.inv(arm_base_pose(r.arms[arm])) @ tool_fk(geometry, arm, q)
        sols = ik_all(base_t_tool0, r.dh_d, r.dh_a, r.dh_alpha, branch=branch)
        wrapped = (q + math.pi) % (2 * math.pi) - math.pi
        assert any(np.abs(s - wrapped).max() < 1e-6 for s in sols), f"q {q}: branch {branch} gives {sols}"
