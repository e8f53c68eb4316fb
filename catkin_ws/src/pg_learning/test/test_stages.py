"""pg_learning.training.stages: which primitive each training stage takes before exploration, and epsilon."""

from __future__ import annotations

from pg_learning.training.stages import STAGES, choose_primitive, epsilon


def test_grasp_stages_always_grasp():
    for name in ("grasp-agnostic", "grasp-goal"):
        assert choose_primitive(STAGES[name], -1.0, 0, 0.5, 5) == "grasp"


def test_push_stage_grasps_early_or_after_max_pushes():
    push = STAGES["push"]
    assert choose_primitive(push, 0.4, 0, 0.5, 5) == "push"
    assert choose_primitive(push, 0.6, 0, 0.5, 5) == "grasp"
    assert choose_primitive(push, 0.4, 5, 0.5, 5) == "grasp"


def test_alternate_stage_threshold_and_push_budget():
    alt = STAGES["alternate"]
    assert choose_primitive(alt, 0.4, 9, 0.5, 5) == "push"  # no budget: the paper's threshold rule alone
    assert choose_primitive(alt, 0.6, 0, 0.5, 5) == "grasp"
    assert choose_primitive(alt, 0.4, 9, 0.5, 5, pushes_in_row=2, push_budget=3) == "push"
    assert choose_primitive(alt, 0.4, 9, 0.5, 5, pushes_in_row=3, push_budget=3) == "grasp"


def test_epsilon_decays_linearly_then_holds():
    assert epsilon(0, 0.5, 0.1, 100) == 0.5
    assert abs(epsilon(50, 0.5, 0.1, 100) - 0.3) < 1e-12
    assert abs(epsilon(500, 0.5, 0.1, 100) - 0.1) < 1e-12 and epsilon(3, 0.5, 0.1, 0) == 0.1
