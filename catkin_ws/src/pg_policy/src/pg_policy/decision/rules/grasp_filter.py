"""Test-time filtering of the grasp Q map before the decision (a deviation from the paper: docs/ARCHITECTURE.md).

Q_g is learned from one labelled cell per grasp, so between labels it is noisy at the scale of a few cells, and its
argmax often sits on a speckle at the target's edge, where a few millimetres of error lose the object (the fingers
close on air: most of the learned policy's failed grasps, docs/RESULTS.md). A filter replaces each cell's value by
a robust value over its neighbourhood, so the argmax moves to where the net is confident over an area:

- ``sym``: average rotation r with r + R/2 (the parallel jaw is symmetric, and the nets are trained on both).
- ``min<k>``: the minimum over a k x k cell square, per rotation (a grasp counts as good as its worst neighbour).
- ``mean<k>``: the mean over a k x k cell square, per rotation.

A spec joins parts with "+": "none", "sym", "min3", "sym+min3". The filtered map takes the place of Q_g
everywhere in the decision (the threshold is compared with its masked max), so a filter also changes how often
the policy pushes. As a test-time rule (pg_policy.decision.rules.rule) it is "grasp_filter:SPEC".
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from pg_core.geometry import Geometry
from pg_policy.decision.option import PolicyOption
from pg_policy.decision.rules.rule import Rule, RuleContext

NONE = "none"
DEFAULT_SPEC = "min3"  # the rule's filter when its entry names none


def _minimum(q: np.ndarray, size: int) -> np.ndarray:
    from scipy import ndimage

    return ndimage.minimum_filter(q, size=(1, size, size), mode="nearest")


def _mean(q: np.ndarray, size: int) -> np.ndarray:
    from scipy import ndimage

    return ndimage.uniform_filter(q, size=(1, size, size), mode="nearest")


SPATIAL: dict[str, Callable[[np.ndarray, int], np.ndarray]] = {"min": _minimum, "mean": _mean}


@dataclass(frozen=True)
class GraspFilter:
    """symmetric: average rotations r and r + R/2; spatial: a SPATIAL key or "" (none); size: its square's side in
    cells (odd, >= 3 when spatial is set)."""

    symmetric: bool = False
    spatial: str = ""
    size: int = 0

    @classmethod
    def parse(cls, spec: str | None) -> GraspFilter:
        """A filter from a spec ("none", "sym", "min3", "mean5", "sym+min3"; None = "none").

        Raises ValueError naming the accepted forms for anything else.
        """
        if spec is None or spec.strip().lower() in ("", NONE):
            return cls()
        symmetric, spatial, size = False, "", 0
        for part in spec.strip().lower().split("+"):
            kind = part.rstrip("0123456789")
            digits = part[len(kind):]
            if part == "sym" and not symmetric:
                symmetric = True
            elif kind in SPATIAL and digits and not spatial and int(digits) >= 3 and int(digits) % 2 == 1:
                spatial, size = kind, int(digits)
            else:
                raise ValueError(f"bad grasp filter {spec!r}: expected 'none' or parts joined by '+' from 'sym' and "
                                 f"one of {', '.join(k + '<k>' for k in SPATIAL)} with k odd >= 3 (e.g. 'sym+min3')")
        return cls(symmetric, spatial, size)

    def __str__(self) -> str:
        parts = (["sym"] if self.symmetric else []) + ([f"{self.spatial}{self.size}"] if self.spatial else [])
        return "+".join(parts) or NONE

    @property
    def active(self) -> bool:
        return self.symmetric or bool(self.spatial)

    def apply(self, q_grasp: np.ndarray) -> np.ndarray:
        """The filtered (R, H, W) float64 map of an (R, H, W) Q_g (R even when symmetric); the input itself when
        the filter is "none". A windowed map (finite on a box of cells, -inf around it: the learned policy's
        q_window) is filtered on that box, edges replicated, and stays -inf around it; cells at least (k - 1) / 2
        inside the box get the full map's values. Raises ValueError for another shape or an odd R with "sym"."""
        q = np.asarray(q_grasp)
        if q.ndim != 3:
            raise ValueError(f"grasp Q map must be (R, H, W), got shape {q.shape}")
        if not self.active:
            return q_grasp
        known = np.isfinite(q).any(axis=0)
        if known.any() and not known.all():
            rows, cols = np.flatnonzero(known.any(axis=1)), np.flatnonzero(known.any(axis=0))
            box = (slice(None), slice(rows[0], rows[-1] + 1), slice(cols[0], cols[-1] + 1))
            out = np.full(q.shape, -np.inf)
            out[box] = self._filtered(q[box])
            return out
        return self._filtered(q)

    def _filtered(self, q: np.ndarray) -> np.ndarray:
        q = q.astype(np.float64)
        if self.symmetric:
            if q.shape[0] % 2:
                raise ValueError(f"'sym' needs an even number of rotations, got {q.shape[0]}")
            q = 0.5 * (q + np.roll(q, q.shape[0] // 2, axis=0))
        if self.spatial:
            q = SPATIAL[self.spatial](q, self.size)
        return q


class GraspFilterRule(Rule):
    """Rule "grasp_filter[:SPEC]": the GraspFilter of SPEC (default "min3") applied to Q_g; a "filter" rule, so the
    Q_g users see (the policy's q_maps) is the filtered map."""

    name = "grasp_filter"
    order = 10
    option = PolicyOption("grasp_filter", "str", "filter of Q_g before the decision: none, sym, min<k>, mean<k> or "
                          "parts joined by '+' (e.g. sym+min3); none removes the rule", metavar="SPEC",
                          rule="grasp_filter", off=NONE)
    primitive = "grasp"
    kind = "filter"

    def __init__(self, grasp_filter: GraspFilter) -> None:
        self.filter = grasp_filter

    @classmethod
    def from_arg(cls, geometry: Geometry, arg: str | None) -> GraspFilterRule:
        return cls(GraspFilter.parse(DEFAULT_SPEC if arg is None else arg))

    def arg(self) -> str | None:
        return str(self.filter)

    def adjust(self, q: np.ndarray, ctx: RuleContext) -> np.ndarray:
        return self.filter.apply(q)

    def reach(self) -> int:
        """The spatial filter's half side (min3: 1 cell); 0 for "sym" and "none"."""
        return (self.filter.size - 1) // 2 if self.filter.spatial else 0
