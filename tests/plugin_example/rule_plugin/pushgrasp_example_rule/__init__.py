"""An example pushgrasp test-time rule plug-in: grasp only cells at least a margin inside the target.

Registered as ``example_inner_grasp`` in the entry-point group ``pushgrasp.rules`` (see this distribution's
pyproject.toml and docs/PLUGINS.md of pushgrasp, "Writing a rule"); a rule list names it like a built-in rule:
``example_inner_grasp`` or ``example_inner_grasp:MARGIN_M``, e.g. `pushgrasp eval --policy lite --rules
grasp_filter:min3,failed_grasps:0.01,example_inner_grasp:0.006,push_landing,edge_guard`.

What it does: a "check" on the grasp map (Q_g). While the target is visible, a grasp candidate (rotation, row, col)
passes when its cell lies at least `margin_m` metres inside the target mask (the mask eroded by that many cells,
4-connected); the rule pipeline re-ranks Q_g's best candidates by this test and every other grasp rule's together.
Grasps at the target's rim close on air when the cell is off by a few millimetres. It takes no decision of its own
(`vetoes_grasp` is False): when no candidate passes, the map stays as the other rules left it. A target narrower
than twice the margin has no inner cell: the rule then has no opinion.

Conventions (pg_core.heightmap): Q maps are (R, H, W) float arrays over R rotations and the heightmap's cells, row
along `world` y, column along x, `resolution` metres per cell.
"""

from __future__ import annotations

import math

import numpy as np

from pg_core.geometry import Geometry
from pg_policy.decision.rules.rule import BatchTest, CandidateTest, Rule, RuleContext

__all__ = ["InnerGrasp"]

MARGIN_M = 0.004  # the default margin: 2 cells at 0.002 m


def eroded(mask: np.ndarray, cells: int) -> np.ndarray:
    """The (H, W) bool `mask` eroded by `cells` cells (4-connected: a cell stays when it and its 4 neighbours do,
    `cells` times over; cells off the map count as outside)."""
    out = np.asarray(mask, dtype=bool).copy()
    for _ in range(cells):
        inner = out.copy()
        inner[1:] &= out[:-1]
        inner[:-1] &= out[1:]
        inner[:, 1:] &= out[:, :-1]
        inner[:, :-1] &= out[:, 1:]
        inner[0], inner[-1], inner[:, 0], inner[:, -1] = False, False, False, False
        out = inner
    return out


class InnerGrasp(Rule):
    """Rule "example_inner_grasp[:MARGIN_M]": a grasp candidate's cell must lie `margin_m` (default MARGIN_M)
    inside the target mask (module docstring)."""

    name = "example_inner_grasp"  # equal to the entry point's name: rule lists and model metadata name it so
    primitive = "grasp"  # the map it acts on
    kind = "check"  # a yes/no test of candidates; it neither reshapes the map nor remembers anything

    def __init__(self, resolution: float, margin_m: float = MARGIN_M) -> None:
        if not margin_m >= 0:
            raise ValueError(f"rule {self.name!r}: the margin must be >= 0 m, got {margin_m}")
        self.margin_m = margin_m
        self.cells = int(math.ceil(margin_m / resolution - 1e-9))

    @classmethod
    def from_arg(cls, geometry: Geometry, arg: str | None) -> InnerGrasp:
        """The rule of the list entry "example_inner_grasp[:MARGIN_M]"; ValueError naming the rule for a bad
        argument."""
        if arg is None:
            return cls(geometry.heightmap.resolution)
        try:
            margin = float(arg)
        except ValueError:
            raise ValueError(f"rule {cls.name!r}: the argument is a margin in metres, got {arg!r}") from None
        return cls(geometry.heightmap.resolution, margin)

    def arg(self) -> str | None:
        return f"{self.margin_m:g}"

    def candidate_test(self, ctx: RuleContext) -> CandidateTest | None:
        if not ctx.visible:
            return None  # ctx.target is then every object cell: no opinion
        inner = eroded(ctx.target, self.cells)
        if not inner.any():
            return None
        return BatchTest(lambda rotations, rows, cols: inner[rows, cols])
