"""The package graph's import contracts (pyproject.toml [tool.importlinter], docs/ARCHITECTURE.md "Packages"): one-way
dependencies between pg_core, pg_conversions, pg_sim, pg_policy and pg_learning (the runtime pg_policy imports neither
the simulator nor the learning package), the layers inside pg_policy, pg_learning and pg_sim, no ROS in the cores,
rules never importing baselines. Checked with import-linter, the way `lint-imports` runs them."""

from __future__ import annotations

import subprocess
import sys
import textwrap
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
LINT_IMPORTS = Path(sys.executable).with_name("lint-imports")


def _lint(config: Path, cwd: Path, pythonpath: str | None = None) -> subprocess.CompletedProcess[str]:
    env = None
    if pythonpath is not None:
        import os

        env = {**os.environ, "PYTHONPATH": pythonpath}
    return subprocess.run([str(LINT_IMPORTS), "--config", str(config), "--no-cache", "--no-logo"], cwd=cwd,
                          capture_output=True, text=True, timeout=300, env=env)


def test_the_project_keeps_every_import_contract():
    # the source trees first: the catkin devel space on the path holds only relay __init__ files of the packages
    pkgs = ("pg_core", "pg_conversions", "pg_sim", "pg_policy", "pg_learning")
    src = [str(REPO / "catkin_ws" / "src" / pkg / "src") for pkg in pkgs]
    res = _lint(REPO / "pyproject.toml", REPO, pythonpath=":".join(src))
    assert res.returncode == 0, res.stdout + res.stderr
    assert "BROKEN" not in res.stdout and " KEPT" in res.stdout


def test_a_broken_contract_fails(tmp_path: Path):
    # a package whose core imports rospy: the same kind of contract must report it
    pkg = tmp_path / "demo_core"
    pkg.mkdir()
    (pkg / "__init__.py").write_text("")
    (pkg / "geometry.py").write_text("import rospy  # noqa: F401\n")
    config = tmp_path / "contracts.toml"
    config.write_text(textwrap.dedent("""
        [tool.importlinter]
        root_packages = ["demo_core"]
        include_external_packages = true

        [[tool.importlinter.contracts]]
        name = "core imports no ROS"
        type = "forbidden"
        source_modules = ["demo_core"]
        forbidden_modules = ["rospy"]
    """))
    res = _lint(config, tmp_path, pythonpath=str(tmp_path))
    assert res.returncode != 0 and "BROKEN" in res.stdout and "demo_core.geometry -> rospy" in res.stdout


def test_an_import_of_the_simulator_in_the_runtime_fails(tmp_path: Path):
    # the runtime contract of pyproject.toml, on a package that reaches pybullet through a function-local import
    pkg = tmp_path / "demo_runtime"
    pkg.mkdir()
    (pkg / "__init__.py").write_text("")
    (pkg / "node.py").write_text("def render():\n    import pybullet  # noqa: F401\n")
    config = tmp_path / "contracts.toml"
    config.write_text(textwrap.dedent("""
        [tool.importlinter]
        root_packages = ["demo_runtime"]
        include_external_packages = true

        [[tool.importlinter.contracts]]
        name = "the runtime imports no simulator"
        type = "forbidden"
        source_modules = ["demo_runtime"]
        forbidden_modules = ["pg_sim", "pybullet", "pybullet_data", "pg_learning"]
    """))
    res = _lint(config, tmp_path, pythonpath=str(tmp_path))
    assert res.returncode != 0 and "demo_runtime.node -> pybullet" in res.stdout, res.stdout + res.stderr


def test_the_catkin_package_graph_is_declared_one_way():
    # every package.xml dependency between our packages, as catkin reads it; the graph must have no cycle, the
    # simulator must not depend on the policy, and the policy (the robot's runtime) not on the simulator or learning
    from catkin_pkg.package import parse_package

    ours = {p.parent.name: parse_package(str(p)) for p in (REPO / "catkin_ws" / "src").glob("*/package.xml")}
    graph = {name: {d.name for d in (*pkg.build_depends, *pkg.exec_depends, *pkg.build_export_depends,
                                     *pkg.test_depends) if d.name in ours}
             for name, pkg in ours.items()}
    assert {"pg_description", "pg_msgs", "pg_core", "pg_conversions", "pg_sim", "pg_control", "pg_policy",
            "pg_learning"} <= set(ours)
    assert "pg_policy" not in graph["pg_sim"] and graph["pg_description"] == set()
    assert not {"pg_sim", "pg_learning"} & graph["pg_policy"] and "pg_learning" not in graph["pg_sim"]
    assert {"pg_policy", "pg_sim"} <= graph["pg_learning"]
    assert graph["pg_core"] == {"pg_description"}
    done: set[str] = set()
    while len(done) < len(graph):  # Kahn: peel off packages whose dependencies are all placed
        ready = {n for n, deps in graph.items() if n not in done and deps <= done}
        assert ready, f"dependency cycle among {sorted(set(graph) - done)}"
        done |= ready
