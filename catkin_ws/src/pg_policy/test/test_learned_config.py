"""The learned policy's typed settings (LearnedConfig: model metadata + policy options, validated once) and its
forced decisions (Force, decision_threshold)."""

from __future__ import annotations

import math

import pytest

from pg_core.target_mask import MIN_VISIBLE_CELLS
from pg_policy.policies.learned import HIDDEN_PUSHES, Force, LearnedConfig, decision_threshold

META = {"thresholds": {"grasp_q": 0.7, "push_budget": 3}, "rules": ["grasp_filter:min3", "edge_guard"]}


def test_the_model_gives_the_values_the_options_leave_unset():
    c = LearnedConfig.from_model(META, {})
    assert c == LearnedConfig(0.7, 3, ("grasp_filter:min3", "edge_guard"), True, True, True, MIN_VISIBLE_CELLS,
                              HIDDEN_PUSHES)
    assert LearnedConfig.from_model({"thresholds": {"grasp_q": 0.5}}, {}).push_budget == 0  # no budget stored
    with pytest.raises(ValueError, match="grasp-threshold"):  # neither the model nor the options have one
        LearnedConfig.from_model({}, {})


def test_options_override_the_model_and_are_parsed_by_their_declaration():
    c = LearnedConfig.from_model(META, {"grasp_threshold": "0.5", "push_budget": 0, "rules": "none",
                                        "edge_guard": "on", "q_window": "off", "forced_grasp": False,
                                        "refused_push": "off", "min_target_cells": "5", "hidden_pushes": 0,
                                        "enclosed_grasp": "on", "unsure_grasp": "off"})
    assert (c.threshold, c.push_budget, c.rules, c.q_window, c.forced_grasp, c.refused_push, c.min_target_cells,
            c.hidden_pushes, c.enclosed_grasp, c.unsure_grasp) == (0.5, 0, ("edge_guard",), False, False, False, 5, 0,
                                                                    True, False)
    assert not LearnedConfig.from_model(META, {}).enclosed_grasp  # unset: off
    assert LearnedConfig.from_model(META, {}).unsure_grasp  # unset: on
    assert LearnedConfig.from_model(META, {"push_budget": None, "q_window": "auto"}).q_window  # unset
    with pytest.raises(AttributeError):
        c.threshold = 1.0  # type: ignore[misc]  # frozen


@pytest.mark.parametrize(("overrides", "named"), [
    ({"push_budget": -1}, "option push_budget: the push budget must be >= 0"),
    ({"push_budget": "many"}, "option push_budget: expected int"),
    ({"min_target_cells": 0}, "option min_target_cells: min_target_cells must be >= 1"),
    ({"hidden_pushes": -2}, "option hidden_pushes: hidden_pushes must be >= 0"),
    ({"grasp_threshold": "nan"}, "option grasp_threshold"),
    ({"forced_grasp": "maybe"}, "option forced_grasp: expected switch"),
    ({"grasp_chek": "jaw"}, "unknown policy option 'grasp_chek'"),
])
def test_a_bad_value_names_its_option(overrides, named):
    with pytest.raises(ValueError, match=named):
        LearnedConfig.from_model(META, overrides)


def test_a_bad_budget_in_the_model_names_the_option_and_the_metadata_key():
    with pytest.raises(ValueError, match=r"option push_budget: the model's thresholds.push_budget"):
        LearnedConfig.from_model({"thresholds": {"grasp_q": 0.7, "push_budget": "x"}}, {})


def test_a_force_becomes_the_threshold_the_decision_compares_with():
    assert decision_threshold(Force.NONE, 0.7) == 0.7
    assert decision_threshold(Force.GRASP, 0.7) == -math.inf
    assert decision_threshold(Force.PUSH, 0.7) == math.inf
    assert {f.value for f in Force} == {"none", "grasp", "push"}
