"""Option unsure_grasp of the learned policy: while a tracked target's track is in doubt (PolicyObservation.unsure),
off makes the policy push instead of grasping until the push budget is spent; on (the default) grasps as Q_g says."""

import numpy as np

from pg_core.geometry import load
from pg_core.heightmap import Heightmap
from pg_policy.policies.policy import PolicyOptions
from pg_policy.policies.registry import make_policy
from pg_policy.target_loop.loop_types import PolicyObservation

GEO = load()
H = W = 224


def _obs(unsure: bool) -> PolicyObservation:
    """A lone 4 x 4 cm block at the centre, named by its mask (a point or mask target's track)."""
    rr, cc = np.mgrid[0:H, 0:W]
    block = (np.abs(rr - H // 2) <= 10) & (np.abs(cc - W // 2) <= 10)
    height = np.where(block, 0.04, 0.0).astype(np.float32)
    color = np.full((H, W, 3), (199, 178, 148), np.uint8)
    color[block] = (120, 120, 120)
    hm = Heightmap(color, height, np.ones((H, W), bool), GEO.heightmap.resolution, GEO.workspace.bounds)
    return PolicyObservation(hm, "point (0.000, 0.000)", mask=block, unsure=unsure)


def test_an_unsure_track_is_pushed_until_the_budget_is_spent_with_the_option_off(model_dir):
    def policy(**options: str):
        return make_policy("learned", PolicyOptions(models=(model_dir,), overrides={"grasp_threshold": -1e9,
                                                                                  "push_budget": 2, **options}))

    default = policy()
    assert default.config.unsure_grasp and default.act(_obs(unsure=True)).primitive == "grasp"
    off = policy(unsure_grasp="off")
    assert off.act(_obs(unsure=False)).primitive == "grasp"  # a sure track: grasp as Q_g says
    off.reset(0)
    first, second = off.act(_obs(unsure=True)), off.act(_obs(unsure=True))
    assert (first.primitive, second.primitive) == ("push", "push") and off.last_note == "target track unsure: push"
    assert off.act(_obs(unsure=True)).primitive == "grasp"  # the budget of 2 pushes is spent
