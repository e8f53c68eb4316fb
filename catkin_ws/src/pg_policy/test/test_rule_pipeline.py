"""pg_policy.decision.rules: the pipeline's order and conjunction, the registry, rule lists old and new, and the
declared options with their launch-file agreement."""

from __future__ import annotations

import re
from pathlib import Path
from xml.etree import ElementTree

import numpy as np
import pytest
from rule_testing import context

from pg_core.geometry import load
from pg_core.heightmap import Heightmap
from pg_policy.decision.rules.pipeline import RulePipeline
from pg_policy.decision.rules.registry import (
    builtin_rule_classes,
    legacy_rules,
    make_pipeline,
    model_rules,
    rule_classes,
    with_switch,
)
from pg_policy.decision.rules.rule import Rule, RuleContext
from pg_policy.policies import options

GEO = load()
H, W = GEO.heightmap.rows, GEO.heightmap.cols
LAUNCH = Path(__file__).resolve().parents[4] / "launch"
SHIPPED = ["grasp_filter:min3", "failed_grasps:0.01", "grasp_check:jaw-walls", "push_landing", "edge_guard"]


class Forbid(Rule):
    """A push test refusing the given cells (for the conjunction)."""

    name = "forbid"
    primitive = "push"

    def __init__(self, cells: set[tuple[int, int, int]], name: str = "forbid") -> None:
        self.cells, self.name = cells, name  # type: ignore[misc]

    def candidate_test(self, ctx: RuleContext):  # type: ignore[no-untyped-def]
        return lambda r, row, col: (r, row, col) not in self.cells


def _flat() -> tuple[Heightmap, np.ndarray]:
    hm = Heightmap(np.zeros((H, W, 3), np.uint8), np.zeros((H, W), np.float32), np.ones((H, W), bool),
                   GEO.heightmap.resolution, GEO.workspace.bounds)
    return hm, np.ones((H, W), bool)


def test_a_push_candidate_must_pass_every_push_rule():
    hm, anywhere = _flat()
    q = np.zeros((16, H, W))
    first, second, third = (0, 10, 10), (1, 20, 20), (2, 30, 30)
    q[first], q[second], q[third] = 3.0, 2.0, 1.0
    a, b = Forbid({first}, "a"), Forbid({second}, "b")  # each alone would pick a cell the other refuses
    res = RulePipeline([a, b]).apply({"grasp": np.zeros_like(q), "push": q}, context(hm, anywhere))
    assert np.unravel_index(np.argmax(res.q["push"]), q.shape) == third and res.q["push"].max() == 3.0
    assert res.rejected["push"] == 2 and not res.vetoed["push"]
    region = np.zeros((H, W), bool)
    for _, row, col in (first, second, third):
        region[row, col] = True
    res = RulePipeline([Forbid({first, second, third} | {(r, row, col) for r in range(16) for row, col in
                                                         np.argwhere(region)})]).apply(
        {"grasp": q, "push": q}, context(hm, anywhere, region))
    np.testing.assert_array_equal(res.q["push"], q)  # no candidate of the region passes: unchanged, but vetoed
    assert res.vetoed["push"] and not res.push_instead  # only a vetoing grasp rule asks for a push


def test_filters_shape_the_shown_map_and_memories_only_the_decision():
    hm, anywhere = _flat()
    rng = np.random.default_rng(0)
    q = rng.random((16, H, W))
    pipe = make_pipeline(["failed_grasps:0.01", "grasp_filter:min3"], GEO)
    pipe["failed_grasps"].add(0, 0.0, 0.0)
    res = pipe.apply({"grasp": q, "push": q}, context(hm, anywhere))
    assert np.isfinite(res.shown["grasp"]).all() and np.isinf(res.q["grasp"]).any()
    np.testing.assert_allclose(res.shown["grasp"], pipe["grasp_filter"].filter.apply(q))


def test_rules_are_found_by_module_and_named_once():
    assert list(builtin_rule_classes()) == ["grasp_filter", "failed_grasps", "futile_pushes", "low_parts",
                                            "grasp_check", "grasp_search", "push_landing", "edge_recentre",
                                            "edge_guard"]
    assert list(rule_classes())[:9] == list(builtin_rule_classes())  # installed plug-ins follow
    assert make_pipeline(SHIPPED, GEO).specs() == SHIPPED
    with pytest.raises(ValueError, match="unknown rule 'fancy'"):
        make_pipeline(["fancy"], GEO)
    with pytest.raises(ValueError, match="once"):
        make_pipeline(["push_landing", "push_landing"], GEO)
    with pytest.raises(ValueError, match="takes no argument"):
        make_pipeline(["push_landing:3"], GEO)


class Shift(Rule):
    """A rule of a given kind adding `by` to the whole map (to see where its adjust runs)."""

    primitive = "grasp"

    def __init__(self, name: str, kind: str, by: float) -> None:
        self.name, self.kind, self.by = name, kind, by  # type: ignore[misc]

    def adjust(self, q: np.ndarray, ctx: RuleContext) -> np.ndarray:
        return q + self.by


def test_the_kind_decides_where_a_rule_adjusts_and_apply_times_every_rule():
    hm, anywhere = _flat()
    q = np.zeros((16, H, W))
    # listed memory first: the filter still runs first (its map is the shown one), the memory after it
    pipe = RulePipeline([Shift("m", "memory", 1.0), Shift("f", "filter", 10.0), Forbid({(0, 0, 0)}, "c")])
    res = pipe.apply({"grasp": q, "push": q}, context(hm, anywhere))
    assert (res.shown["grasp"] == 10.0).all() and res.q["grasp"].max() == 11.0
    assert list(pipe.timings) == ["m", "f", "c", "rerank"] and all(t >= 0.0 for t in pipe.timings.values())
    assert pipe.timings["c"] > 0.0  # the push test, asked during the re-rank of Q_p, is charged to its rule
    assert [Shift("x", k, 0.0).reach() for k in ("filter", "memory", "check", "override")] == [None, 0, 0, 0]
    with pytest.raises(ValueError, match="unknown rule kind 'layer'"):
        RulePipeline([Shift("x", "layer", 0.0)])


class Raise(Rule):
    """An override raising one push cell above the map's best value (as edge_recentre does)."""

    name = "raise"
    primitive = "push"
    kind = "override"

    def __init__(self, cell: tuple[int, int, int]) -> None:
        self.cell = cell

    def adjust(self, q: np.ndarray, ctx: RuleContext) -> np.ndarray:
        out = q.copy()
        out[self.cell] = q.max() + 1.0
        return out


def test_an_override_comes_first_and_still_faces_the_checks():
    hm, anywhere = _flat()
    q = np.zeros((16, H, W))
    best, raised = (0, 10, 10), (3, 40, 40)
    q[best] = 1.0
    res = RulePipeline([Raise(raised), Forbid(set())]).apply({"grasp": q, "push": q}, context(hm, anywhere))
    assert np.unravel_index(np.argmax(res.q["push"]), q.shape) == raised and not res.vetoed["push"]
    assert (res.shown["push"] == q).all()  # not a filter: the map users see is the net's
    res = RulePipeline([Raise(raised), Forbid({raised})]).apply({"grasp": q, "push": q}, context(hm, anywhere))
    assert np.unravel_index(np.argmax(res.q["push"]), q.shape) == best  # refused by a check: the net's best


def test_models_before_rule_lists_map_their_switches_to_the_same_rules():
    old = {"grasp_q": 0.7, "grasp_filter": "min3", "grasp_check": "jaw-walls", "edge_guard": True,
           "push_landing": True}
    assert legacy_rules(old) == SHIPPED
    assert model_rules({"thresholds": {"grasp_q": 0.5}}) == ["failed_grasps:0.01"]  # the paper's rule + memory
    assert model_rules({"rules": ["edge_guard"], "thresholds": old}) == ["edge_guard"]  # a list wins
    with pytest.raises(ValueError, match="list"):
        model_rules({"rules": "edge_guard"})


def test_options_switch_rules_in_place_or_at_their_order():
    assert with_switch(SHIPPED, "grasp_check", "grasp_check:jaw") == [
        "grasp_filter:min3", "failed_grasps:0.01", "grasp_check:jaw", "push_landing", "edge_guard"]
    assert with_switch(SHIPPED, "futile_pushes", "futile_pushes:0.01")[2] == "futile_pushes:0.01"
    assert with_switch(SHIPPED, "low_parts", "low_parts")[2:4] == ["low_parts", "grasp_check:jaw-walls"]
    assert options.resolved_rules(SHIPPED, {"grasp_check": "none", "edge_guard": "off"}) == [
        "grasp_filter:min3", "failed_grasps:0.01", "push_landing"]
    assert options.resolved_rules(SHIPPED, {"failed_grasp_radius": 0.0}) == [
        "grasp_filter:min3", "grasp_check:jaw-walls", "push_landing", "edge_guard"]
    assert options.resolved_rules(SHIPPED, {"rules": "none", "push_landing": "on"}) == ["push_landing"]
    with pytest.raises(ValueError, match="grasp_check: expected one of"):
        options.resolved_rules(SHIPPED, {"grasp_check": "fancy"})
    with pytest.raises(ValueError, match="unknown policy option"):
        options.resolved_rules(SHIPPED, {"grasp_chek": "jaw"})


def test_parameters_and_flags_come_from_the_declaration():
    params = {"~grasp_check": "jaw", "~edge_guard": False, "~grasp_threshold": "auto", "~push_budget": 2}
    assert options.from_params(lambda name, default: params.get(name, default)) == {
        "grasp_check": "jaw", "edge_guard": False, "push_budget": 2}
    with pytest.raises(ValueError, match="~push_landing"):
        options.from_params(lambda name, default: "maybe" if name == "~push_landing" else default)
    import argparse

    parser = argparse.ArgumentParser()
    options.add_arguments(parser)
    args = parser.parse_args(["--grasp-check", "none", "--edge-guard", "on", "--futile-push-radius", "0.01"])
    assert options.from_args(args) == {"grasp_check": "none", "edge_guard": True, "futile_push_radius": 0.01}


def test_help_shows_the_policy_defaults_and_export_offers_only_what_a_model_carries():
    import argparse

    from pg_core.target_mask import MIN_VISIBLE_CELLS
    from pg_policy.policies.learned import HIDDEN_PUSHES

    # the defaults --help and the launch files show are the values the policy uses when the option is unset
    assert options.option("min_target_cells").default == str(MIN_VISIBLE_CELLS)
    assert options.option("hidden_pushes").default == str(HIDDEN_PUSHES)
    parser = argparse.ArgumentParser()
    options.add_arguments(parser)
    text = " ".join(parser.format_help().split())
    assert f"hidden, searched for where it was last seen (default: {MIN_VISIBLE_CELLS})" in text
    assert "(default: the model's own)" in text  # the model options
    export = argparse.ArgumentParser()
    options.add_arguments(export, model_only=True)
    flags = {a.dest for a in export._actions}
    assert {"grasp_threshold", "push_budget", "rules", "grasp_check"} <= flags
    assert not flags & {"min_target_cells", "hidden_pushes", "forced_grasp", "q_window"}


@pytest.mark.parametrize("name", ["sim.launch", "robot.launch", "pushgrasp_core.launch"])
def test_the_launch_files_declare_every_option(name: str):
    ElementTree.parse(LAUNCH / name)  # well-formed XML (roslaunch parses it the same way)
    text = (LAUNCH / name).read_text()
    lines = [line.strip() for line in text.splitlines()]
    for kind in ("args", "pass", "params") if name != "pushgrasp_core.launch" else ("args", "params"):
        block = options.launch_block(kind)
        if kind == "pass" or (kind == "params") == (name == "pushgrasp_core.launch"):
            start = [i for i, line in enumerate(lines) if line == block[0]]
            assert any(lines[i:i + len(block)] == block for i in start), \
                f"{name}: the {kind} block differs; run python -m pg_policy.policies.options --launch launch/{name}"
    declared = set(re.findall(r'<arg name="(\w+)" default=', text))
    assert {o.name for o in options.options()} <= declared
