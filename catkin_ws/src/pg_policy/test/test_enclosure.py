"""pg_policy.decision.enclosure: a target inside a vessel's walls, and targets that are not."""

from dataclasses import dataclass

import numpy as np
import pytest

from pg_core.geometry import load
from pg_core.heightmap import Heightmap
from pg_core.palette import PALETTE
from pg_policy.decision.enclosure import target_enclosed
from pg_policy.policies.policy import PolicyOptions
from pg_policy.policies.registry import make_policy

GEO = load()
RES = GEO.heightmap.resolution
H = W = 224


def _scene(wall_radius_m: float | None, wall_height: float = 0.09, arc_deg: float = 360.0,
           brick_height: float = 0.02) -> tuple[Heightmap, np.ndarray]:
    """A 3 x 1.6 cm brick at the centre, and (unless None) a 4 mm thick wall of a cup around it spanning
    `arc_deg` degrees from +x."""
    rr, cc = np.mgrid[0:H, 0:W]
    dy, dx = (rr - H // 2) * RES, (cc - W // 2) * RES
    height = np.zeros((H, W), np.float32)
    if wall_radius_m is not None:
        r = np.hypot(dx, dy)
        ang = np.degrees(np.arctan2(dy, dx)) % 360
        height[(np.abs(r - wall_radius_m) <= 0.002) & (ang <= arc_deg)] = wall_height
        height[(r < wall_radius_m - 0.002) & (height == 0)] = 0.006  # the cup's floor
    brick = (np.abs(dx) <= 0.015) & (np.abs(dy) <= 0.008)
    height[brick] = brick_height
    color = np.full((H, W, 3), (199, 178, 148), np.uint8)
    color[height > 0.008] = PALETTE["blue"]
    color[brick] = PALETTE["green"]
    hm = Heightmap(color, height, np.ones((H, W), bool), RES, GEO.workspace.bounds)
    return hm, brick


def test_a_brick_inside_a_cup_is_enclosed():
    assert target_enclosed(*_scene(0.035))


def test_a_brick_beside_a_wall_or_in_the_open_is_not():
    assert not target_enclosed(*_scene(None))
    assert not target_enclosed(*_scene(0.035, arc_deg=180))  # half a wall: one side open
    assert not target_enclosed(*_scene(0.09))  # walls beyond the reach: a wide bowl's floor, not a cup
    assert not target_enclosed(*_scene(0.035, wall_height=0.03))  # a low rim: not 2 cm above the brick


def test_an_empty_or_misshaped_mask_is_handled():
    hm, brick = _scene(0.035)
    assert not target_enclosed(hm, np.zeros_like(brick))
    with pytest.raises(ValueError, match="differ"):
        target_enclosed(hm, brick[:-1])


@dataclass
class _Obs:
    heightmap: Heightmap
    target: str = "green"


def test_the_learned_policy_grasps_an_enclosed_target_at_once_with_the_option_on(model_dir):
    # Q_g below the threshold everywhere: with enclosed_grasp on the policy grasps the brick in the cup at once;
    # off (the default), or with half the wall, it pushes
    def act(wall_arc: float, **options: str):
        pol = make_policy("learned", PolicyOptions(models=(model_dir,), overrides={"grasp_threshold": 1e9,
                                                                                  **options}))
        return pol, pol.act(_Obs(_scene(0.035, arc_deg=wall_arc)[0]))

    pol, d = act(360, enclosed_grasp="on")
    assert d.primitive == "grasp" and pol.last_note.startswith("target inside a vessel")
    default, d = act(360)
    assert not default.config.enclosed_grasp and d.primitive == "push"
    assert act(180, enclosed_grasp="on")[1].primitive == "push"
