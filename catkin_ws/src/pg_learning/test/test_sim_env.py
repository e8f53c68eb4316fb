"""pg_learning.environment.sim_env: a policy decides on the simulator's observation and the simulator executes it."""

from __future__ import annotations

from pg_learning.environment.sim_env import SimEnv
from pg_policy.policies.registry import make_policy
from pg_sim.scenes.colors import resolve_color
from pg_sim.scenes.scene import ObjectSpec, SceneSpec


def test_heuristic_grasps_an_isolated_target_in_the_sim():
    objs = (ObjectSpec("cube", None, resolve_color("green"), (0.04, -0.03, 0.0226, 0, 0, 0.4), target=True,
                       name="target"),
            ObjectSpec("rect", None, resolve_color("blue"), (-0.1, 0.1, 0.0226, 0, 0, 1.0), name="other"))
    with SimEnv() as env:
        obs = env.reset(SceneSpec("isolated", "green", objs, "test"))
        pol = make_policy("heuristic")
        pol.reset(0)
        d = pol.act(obs)
        assert d.primitive == "grasp"
        res = env.step(d.primitive, d.x, d.y, d.z, d.yaw)
        assert res.target_grasped, res.message
