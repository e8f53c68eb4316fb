"""Within-trial memory of grasps that failed, so a deterministic greedy policy does not repeat one.

A trial's policy is asked to act again only if its previous grasp did not end the trial, i.e. did not grasp the
target (pg_learning.evaluation.runner and pg_policy.target_loop.target_loop reset the policy per trial). After a failed
grasp the scene
around it has barely changed, so the argmax of Q_g lands on (nearly) the same cell and rotation again: the
learned policy burned up to 5 attempts that way (docs/RESULTS.md). Suppressing the cells within `radius_m` of a
failed grasp, at the same closing axis (rotation r and r + R/2: the parallel jaw is symmetric), makes the next
grasp try something else; everything else in the Q map is unchanged. As a test-time rule (pg_policy.decision.rules.rule)
it is "failed_grasps[:RADIUS_M]".
"""

from __future__ import annotations

from typing import Any

import numpy as np

from pg_core.geometry import Geometry
from pg_core.heightmap import Heightmap, cell_centre_axes
from pg_policy.decision.option import PolicyOption
from pg_policy.decision.rules.rule import Rule, RuleContext, parse_metres

DEFAULT_RADIUS_M = 0.01  # a failed grasp's closing axis is not retried within 1 cm (5 cells at 0.002 m)


class FailedGrasps(Rule):
    """Rule "failed_grasps[:RADIUS_M]": grasps (rotation index, x, y in `world` metres) that failed in the current
    trial, suppressed in Q_g within `radius_m` (default DEFAULT_RADIUS_M)."""

    name = "failed_grasps"
    order = 20
    option = PolicyOption("failed_grasp_radius", "float", "a failed grasp's closing axis is not retried within this "
                          "radius (m) in the same trial; 0 removes the rule", metavar="M", rule="failed_grasps",
                          off=0.0)
    primitive = "grasp"
    kind = "memory"

    def __init__(self, rotations: int, radius_m: float = DEFAULT_RADIUS_M) -> None:
        if radius_m < 0:
            raise ValueError(f"failed-grasp radius must be >= 0 m, got {radius_m}")
        self.rotations = rotations
        self.radius_m = radius_m
        self.grasps: list[tuple[int, float, float]] = []

    @classmethod
    def from_arg(cls, geometry: Geometry, arg: str | None) -> FailedGrasps:
        return cls(geometry.heightmap.rotations, DEFAULT_RADIUS_M if arg is None else parse_radius(cls.name, arg))

    def arg(self) -> str | None:
        return f"{self.radius_m:g}"

    def clear(self) -> None:
        self.grasps = []

    def reset(self) -> None:
        self.clear()

    def observe(self, last: Any, before: RuleContext, after: RuleContext) -> None:
        if last.primitive == "grasp":  # asked again: that grasp missed the target
            self.add(last.rotation, last.x, last.y)

    def adjust(self, q: np.ndarray, ctx: RuleContext) -> np.ndarray:
        return self.suppress(q, ctx.heightmap)

    def add(self, rotation: int, x: float, y: float) -> None:
        self.grasps.append((int(rotation), float(x), float(y)))

    def suppress(self, q_grasp: np.ndarray, hm: Heightmap) -> np.ndarray:
        """A float copy of the (R, H, W) grasp Q map with -inf at every remembered grasp's closing axis within
        `radius_m` of its (x, y); the input is returned unchanged (not copied) when nothing is remembered or the
        radius is 0."""
        half = self.rotations // 2
        axes = [((r % half, r % half + half), x, y) for r, x, y in self.grasps]
        return suppress_near(q_grasp, hm, axes, self.radius_m)


def parse_radius(rule: str, arg: str) -> float:
    """A radius in metres from a rule's argument; ValueError naming the rule for a non-number or a negative one."""
    return parse_metres(rule, arg, "radius")


def suppress_near(q: np.ndarray, hm: Heightmap, actions: list[tuple[tuple[int, ...], float, float]],
                  radius_m: float) -> np.ndarray:
    """A float copy of the (R, H, W) Q map `q` over `hm`'s cells with -inf, for each (rotation indices, x, y) of
    `actions` (x, y in `world` metres), at those rotations within `radius_m` of (x, y); `q` itself (not copied)
    when `actions` is empty or the radius is 0."""
    if not actions or radius_m == 0:
        return q
    out = np.array(q, dtype=np.float64, copy=True)
    rows, cols = out.shape[1:]
    xs, ys = cell_centre_axes(rows, cols, hm.bounds, hm.resolution)
    for rotations, x, y in actions:
        near = (ys[:, None] - y) ** 2 + (xs[None, :] - x) ** 2 <= radius_m**2
        for r in rotations:
            out[r][near] = -np.inf
    return out
