"""Third-party test-time rules through the entry-point group `pushgrasp.rules` (docs/PLUGINS.md, "Writing a rule").

The example distribution tests/plugin_example/rule_plugin (`pushgrasp-example-rule`, rule `example_inner_grasp`) is
installed into the running interpreter's environment for this module, offline (`pip install --no-deps
--no-build-isolation --no-index` from a copy, so no build products land in the source tree), and uninstalled
afterwards unless it was installed before. Then: the rule registry finds it beside the built-in rules, `pushgrasp
policies` lists it with its distribution, a rule pipeline runs it, and the learned policy runs it from `--rules`.
Broken plug-ins (an entry point that does not load, a class that is no rule, a name clash with a built-in rule) give
errors naming the entry point and its distribution; those tests use stand-in entry points and install nothing.
"""

from __future__ import annotations

import importlib
import shutil
import subprocess
from collections.abc import Iterator
from pathlib import Path
from types import SimpleNamespace
from typing import Any

import numpy as np
import pytest
from plugin_install import installed, pip, pushgrasp

REPO = Path(__file__).resolve().parents[1]
PLUGIN_SRC = REPO / "tests" / "plugin_example" / "rule_plugin"
DIST = "pushgrasp-example-rule"
RULE = "example_inner_grasp"
TARGET = "pushgrasp_example_rule:InnerGrasp"
CLI_TIMEOUT_S = 120
GREEN = (89, 161, 79)


@pytest.fixture(scope="module")
def example_rule(tmp_path_factory: pytest.TempPathFactory) -> Iterator[str]:
    """Install the example rule plug-in (offline) for the module; uninstall it afterwards unless it was there
    before. The rule registry is re-read after each."""
    from pg_policy.decision.rules.registry import reload_rules

    was_installed = installed(DIST)
    src = tmp_path_factory.mktemp("rule_plugin") / "rule_plugin"
    shutil.copytree(PLUGIN_SRC, src, ignore=shutil.ignore_patterns("build", "*.egg-info", "__pycache__"))
    res = pip("install", "--no-deps", "--no-build-isolation", "--no-index", "-q", str(src))
    try:
        assert res.returncode == 0, f"offline install of {PLUGIN_SRC} failed:\n{res.stdout}{res.stderr}"
        importlib.invalidate_caches()
        reload_rules()
        yield DIST
    finally:
        if not was_installed:
            out = pip("uninstall", "-y", "-q", DIST)
            assert out.returncode == 0, f"uninstalling {DIST} failed:\n{out.stdout}{out.stderr}"
            assert not installed(DIST), f"{DIST} is still installed"
        importlib.invalidate_caches()
        reload_rules()


def _scene() -> tuple[Any, np.ndarray]:
    """(heightmap, target mask): a green block of 20 x 30 cells, 4.5 cm tall, on an empty table."""
    from pg_core.geometry import load
    from pg_core.heightmap import Heightmap

    g = load()
    h, w = g.heightmap.rows, g.heightmap.cols
    color = np.empty((h, w, 3), np.uint8)
    color[:] = (199, 178, 148)
    height = np.zeros((h, w), np.float32)
    target = np.zeros((h, w), bool)
    target[100:120, 100:130] = True
    color[target], height[target] = GREEN, 0.045
    return Heightmap(color, height, np.ones((h, w), bool), g.heightmap.resolution, g.workspace.bounds), target


# -- the registry and the listing --------------------------------------------------------------------------------
def test_the_registry_finds_the_plugin_beside_the_built_in_rules(example_rule: str) -> None:
    from pg_policy.decision.rules.registry import builtin_rule_classes, rule_classes, rule_entries

    entry = rule_entries()[RULE]
    assert entry.origin.replace("_", "-").lower() == example_rule and entry.target == TARGET, entry
    assert entry.cls.__name__ == "InnerGrasp" and entry.cls.primitive == "grasp" and entry.cls.kind == "check"
    names = list(rule_classes())
    assert names[: len(builtin_rule_classes())] == list(builtin_rule_classes()) and names[-1] == RULE
    assert all(rule_entries()[n].origin == "built-in" for n in builtin_rule_classes())


def test_policies_lists_the_rule_with_its_distribution(example_rule: str) -> None:
    res = subprocess.run(pushgrasp("policies"), cwd=REPO, capture_output=True, text=True, timeout=CLI_TIMEOUT_S)
    assert res.returncode == 0, res.stdout + res.stderr
    rows = [line.split() for line in res.stdout.splitlines()]
    listed = [r for r in rows if r and r[0] == RULE]
    assert listed and listed[0][1:4] == ["grasp", "check", "-"], res.stdout
    assert listed[0][4].replace("_", "-").lower() == example_rule, listed
    assert "pushgrasp.rules" in res.stdout


# -- running it --------------------------------------------------------------------------------------------------
def test_the_plugin_rule_runs_in_a_pipeline(example_rule: str) -> None:
    """Q_g's best cell lies on the target's rim: the rule moves the grasp 3 cells (0.006 m) inside, the compared
    value stays the map's best, and the pipeline times it like any rule."""
    from pg_core.geometry import load
    from pg_policy.decision.decision import masked_argmax, regions
    from pg_policy.decision.rules.registry import make_pipeline
    from pg_policy.decision.rules.rule import RuleContext

    hm, target = _scene()
    specs = ["grasp_filter:none", "failed_grasps:0.01", f"{RULE}:0.006", "push_landing"]
    pipe = make_pipeline(specs, load())
    assert pipe.specs() == ["grasp_filter:none", "failed_grasps:0.01", f"{RULE}:0.006", "push_landing"]
    assert RULE in pipe and pipe[RULE].cells == 3
    q = np.zeros((16, *target.shape))
    q[5, 100, 110] = 2.0  # the rim
    q[3, 101, 111] = 1.5  # one cell inside: still too near the rim
    q[7, 104, 115] = 1.0  # four cells inside
    ctx = RuleContext(hm, target, True, *regions(target, hm))
    out = pipe.apply({"grasp": q, "push": q}, ctx)
    r, row, col, value = masked_argmax(out.q["grasp"], ctx.grasp_region)
    assert (r, row, col) == (7, 104, 115) and value == 2.0, (r, row, col, value)
    assert out.rejected["grasp"] == 2 and not out.vetoed["grasp"] and not out.push_instead
    np.testing.assert_array_equal(out.shown["grasp"], q)  # a check leaves the shown map alone
    assert set(pipe.timings) == {*(s.split(":")[0] for s in specs), "rerank"}
    assert pipe.timings[RULE] > 0.0
    hidden = RuleContext(hm, target, False, *regions(target, hm))  # no opinion while the target is hidden
    assert pipe[RULE].candidate_test(hidden) is None
    with pytest.raises(ValueError, match=f"rule '{RULE}': the argument is a margin"):
        make_pipeline([f"{RULE}:wide"], load())


def test_the_learned_policy_runs_the_plugin_from_its_rule_list(example_rule: str) -> None:
    from pg_policy.policies.policy import PolicyOptions
    from pg_policy.policies.registry import make_policy

    rules = f"grasp_filter:min3,failed_grasps:0.01,{RULE}:0.006,push_landing,edge_guard"
    pol = make_policy("lite", PolicyOptions(overrides={"rules": rules, "grasp_threshold": -1e9}))
    assert pol.rules.specs() == rules.split(",")  # type: ignore[attr-defined]
    hm, _ = _scene()
    d = pol.act(SimpleNamespace(heightmap=hm, target="green"))
    assert d.primitive == "grasp" and 103 <= d.row < 117 and 103 <= d.col < 127, d  # 3 cells inside the block
    assert f"rule:{RULE}" in pol.last_timings  # type: ignore[attr-defined]


# -- broken plug-ins ---------------------------------------------------------------------------------------------
class NotARule:
    """An entry point's target that is no Rule subclass."""


class FakeEntryPoint:
    """What the registry reads of an importlib.metadata.EntryPoint: name, value, dist and load()."""

    def __init__(self, name: str, value: str, dist: str) -> None:
        self.name, self.value, self.dist = name, value, SimpleNamespace(name=dist)

    def load(self) -> Any:
        module, _, attr = self.value.partition(":")
        obj: Any = importlib.import_module(module)
        for part in attr.split("."):
            obj = getattr(obj, part)
        return obj


@pytest.fixture
def plugins(monkeypatch: pytest.MonkeyPatch) -> Iterator[Any]:
    """Set the group's entry points to stand-ins: plugins(FakeEntryPoint, ...)."""
    from pg_policy.decision.rules import registry

    def install(*eps: FakeEntryPoint) -> None:
        monkeypatch.setattr(registry, "entry_points", lambda group: list(eps) if group == "pushgrasp.rules" else [])
        registry.reload_rules()

    yield install
    monkeypatch.undo()
    registry.reload_rules()


def test_a_plugin_that_does_not_load_names_its_entry_point_and_distribution(plugins: Any,
                                                                          capsys: pytest.CaptureFixture[str]) -> None:
    import argparse

    from pg_core.geometry import load
    from pg_policy.cli import policies as policies_cli
    from pg_policy.decision.rules.registry import RulePluginError, make_pipeline, parse_spec

    plugins(FakeEntryPoint("fancy_check", "no_such_module_xyz:Fancy", "broken-dist"))
    assert parse_spec("fancy_check:3") == ("fancy_check", "3")  # known by name; loaded when used
    make_pipeline(["grasp_filter:min3", "edge_guard"], load())  # the other rules are unaffected
    with pytest.raises(RulePluginError) as err:
        make_pipeline(["fancy_check"], load())
    text = str(err.value)
    assert "'fancy_check'" in text and "broken-dist" in text and "no_such_module_xyz:Fancy" in text, text
    assert "pushgrasp.rules" in text and "ModuleNotFoundError" in text, text
    assert isinstance(err.value, ValueError)  # the CLI reports it as a usage error
    assert policies_cli._run(argparse.Namespace()) == 0  # the listing shows the reason in the plug-in's row
    rows = {line.split()[0]: line for line in capsys.readouterr().out.splitlines() if line.startswith("  ")}
    assert "broken-dist" in rows["fancy_check"] and "cannot load" in rows["fancy_check"], rows
    assert rows["edge_guard"].split()[1:] == ["push", "check", "--edge-guard"], rows


def test_a_plugin_that_is_no_rule_or_misnamed_is_a_clear_error(plugins: Any) -> None:
    from pg_core.geometry import load
    from pg_policy.decision.rules.registry import RulePluginError, make_rule

    plugins(FakeEntryPoint("not_a_rule", f"{__name__}:NotARule", "odd-dist"),
            FakeEntryPoint("other_name", "pg_policy.decision.rules.edge_guard:EdgeGuard", "copy-dist"))
    with pytest.raises(RulePluginError, match=r"not_a_rule.*odd-dist.*not a subclass of .*Rule"):
        make_rule("not_a_rule", load())
    with pytest.raises(RulePluginError, match=r"other_name.*copy-dist.*'edge_guard'.*must equal"):
        make_rule("other_name", load())


def test_a_plugin_called_like_a_built_in_rule_is_refused(plugins: Any) -> None:
    from pg_policy.decision.rules.registry import RulePluginError, rule_entries

    plugins(FakeEntryPoint("edge_guard", "somewhere:EdgeGuard", "clash-dist"))
    with pytest.raises(RulePluginError) as err:
        rule_entries()
    text = str(err.value)
    assert "'edge_guard'" in text and "clash-dist" in text and "built-in rule" in text, text
    assert "pg_policy.decision.rules.edge_guard:EdgeGuard" in text, text
