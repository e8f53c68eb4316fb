"""pg_policy.decision.rules.failed_grasps: which Q values a remembered failed grasp suppresses."""

from __future__ import annotations

import numpy as np
import pytest

from pg_core.geometry import load
from pg_core.heightmap import Heightmap, pixel_to_world
from pg_policy.decision.rules.failed_grasps import FailedGrasps

G = load()
N = G.heightmap.rows


def _hm() -> Heightmap:
    return Heightmap(np.zeros((N, N, 3), np.uint8), np.zeros((N, N), np.float32), np.ones((N, N), bool),
                     G.heightmap.resolution, G.workspace.bounds)


def test_suppresses_the_closing_axis_near_the_failed_grasp_only():
    hm, q = _hm(), np.random.default_rng(0).random((16, N, N))
    mem = FailedGrasps(16, radius_m=0.01)
    assert mem.suppress(q, hm) is q  # nothing remembered: untouched
    x, y = pixel_to_world(100, 80, hm.bounds, hm.resolution)
    mem.add(3, x, y)
    out = mem.suppress(q, hm)
    assert np.isneginf(out[3, 100, 80]) and np.isneginf(out[11, 100, 80])  # r and r + R/2: same closing axis
    assert np.isneginf(out[3, 104, 80]) and np.isfinite(out[3, 106, 80])  # 4 cells = 8 mm in, 6 cells = 12 mm out
    assert np.isfinite(out[4, 100, 80]) and np.isfinite(out[2, 100, 80])  # other closing axes stay
    assert np.array_equal(q[np.isfinite(out)], out[np.isfinite(out)]) and np.isfinite(q).all()  # a copy
    mem.clear()
    assert mem.suppress(q, hm) is q


def test_zero_radius_is_off_and_negative_is_refused():
    hm, q = _hm(), np.ones((16, N, N))
    mem = FailedGrasps(16, radius_m=0.0)
    mem.add(0, 0.0, 0.0)
    assert mem.suppress(q, hm) is q
    with pytest.raises(ValueError, match="radius"):
        FailedGrasps(16, radius_m=-0.01)


def test_as_a_rule_it_remembers_a_grasp_the_trial_asked_past():
    from types import SimpleNamespace

    from rule_testing import context

    hm = _hm()
    rule = FailedGrasps.from_arg(load(), None)
    assert rule.spec() == "failed_grasps:0.01"
    ctx = context(hm, np.ones(hm.height.shape, bool))
    rule.observe(SimpleNamespace(primitive="push", rotation=3, x=0.0, y=0.0), ctx, ctx)
    assert rule.grasps == []  # a push is not a failed grasp
    rule.observe(SimpleNamespace(primitive="grasp", rotation=3, x=0.0, y=0.0), ctx, ctx)
    q = np.ones((16, *hm.height.shape))
    assert np.isinf(rule.adjust(q, ctx)).any()
    rule.reset()
    assert rule.adjust(q, ctx) is q
    with pytest.raises(ValueError, match="radius"):
        FailedGrasps.from_arg(load(), "wide")
