"""The `learned` policy: the grasp and push nets, the model's test-time rules, and the paper's decision rule.

Per decision (the paper's loop at test time):
1. perceive: the target mask (while the target is not visible: what covers the place the episode's target memory
   last saw it, `obs.search`, else every object cell) and the regions;
2. Q maps: both nets over the 16 rotations (pg_policy.models.inference), by default only on the cells around the
   grasp and the push region that the rules and the decision read (option q_window; exact: the full maps' values
   there, every other cell -inf);
3. rules: the model's rule pipeline adjusts the maps (pg_policy.decision.rules; first told what the last action did);
   the pushes the episode's memory found futile are suppressed in Q_p first (same rotation, within its radius);
4. decide: grasp if the masked max Q_g exceeds the threshold, else push (pg_policy.decision.decision.decide); a push
   budget B > 0 grasps after B pushes in a row whatever Q_g says (as the paper's push stage does in training), and a
   vetoing grasp rule pushes instead within the budget; while the target is hidden it pushes until HIDDEN_PUSHES
   pushes in a row (option hidden_pushes), since every neighbour a grasp lifts counts as a failed grasp. A grasp
   the budget forces while no candidate passes the grasp rules goes to the best cell passing their weaker fallback
   tests (option forced_grasp, on by default; RulePipeline.forced_grasp), else to Q_g's argmax. A push that the
   push rules refuse is never made: when they refuse every push candidate they test (the edge guard: each would
   carry the target out of the workspace), the policy grasps as a spent budget does (option refused_push, on).
   With option enclosed_grasp (off by default: no significant gain yet), a visible target inside a vessel (walls
   2 cm above it on every side within 5 cm: a small object in a cup or a mug; pg_policy.decision.enclosure) is
   grasped at once, as a spent budget does, instead of pushing the vessel, whose thin rim the closed fingers of a
   push come down on, throwing the object out (docs/RESULTS.md, "Where the household losses are").
The threshold and budget come from the grasp model's metadata (thresholds.grasp_q, push_budget), the rule list from
its `rules` (or the switches of older models); PolicyOptions overrides any of them (pg_policy.policies.options). The
policy reads them once into a LearnedConfig. What the policy must do whatever Q_g says (a spent push budget, a veto,
a hidden target) is a Force, which `decision_threshold` turns into the threshold decide() compares with.
"""

from __future__ import annotations

import math
import time
from collections.abc import Mapping
from dataclasses import dataclass
from enum import Enum
from typing import Any

import numpy as np

from pg_core.target_mask import MIN_VISIBLE_CELLS
from pg_policy.decision.decision import Decision, decide, regions
from pg_policy.decision.enclosure import target_enclosed
from pg_policy.decision.rules.failed_grasps import suppress_near
from pg_policy.decision.rules.registry import make_pipeline, model_rules
from pg_policy.decision.rules.rule import RuleContext
from pg_policy.models.inference import target_window
from pg_policy.policies.model_files import load_nets, metadata_thresholds, resolve_models, threshold_from_metadata
from pg_policy.policies.options import HIDDEN_PUSHES, option, resolved_rules
from pg_policy.policies.policy import PolicyBase, PolicyOptions, goal_of

# Cells of Q computed beyond a region: each rule's `reach` (the grasp filter's k x k squares read (k - 1) / 2 cells
# around a cell; the shipped min3 reads 1), this many for a filter rule whose reach is unknown. A primitive without
# filter rules needs its region only.
WINDOW_MARGIN_CELLS = 4


class Force(Enum):
    """What a decision must be whatever Q_g says against the threshold. NONE: the threshold decides; GRASP: grasp
    at Q_g's best cell of the grasp region (a push only when that region holds no finite Q_g: nothing to grasp);
    PUSH: push."""

    NONE = "none"
    GRASP = "grasp"
    PUSH = "push"


def decision_threshold(force: Force, threshold: float) -> float:
    """The grasp threshold that makes pg_policy.decision.decision.decide (grasp when the masked max of Q_g exceeds
    it) do what `force` asks: -inf for GRASP, +inf for PUSH, `threshold` for NONE. decide takes a threshold only;
    this is the one place a Force becomes one."""
    return {Force.NONE: threshold, Force.GRASP: -math.inf, Force.PUSH: math.inf}[force]


@dataclass(frozen=True)
class LearnedConfig:
    """The learned policy's decision settings, each the value of the policy option of the same name
    (pg_policy.policies.options), else the model's own, else the policy's default. threshold: grasp when the masked
    max of Q_g exceeds it (option grasp_threshold; metadata thresholds.grasp_q); push_budget: grasp after this many
    pushes in a row, 0: no budget (thresholds.push_budget, default 0); rules: the rule list, "name" or "name:arg"
    entries (the model's `rules` edited by the rule options); q_window: Q only around the regions (default on);
    forced_grasp: a grasp the budget forces goes to the grasp rules' fallback tests (default on); refused_push: when
    the push rules refuse every push candidate, grasp as a spent budget does (default on); min_target_cells:
    the target is visible from this many cells (default pg_core.target_mask.MIN_VISIBLE_CELLS); hidden_pushes:
    pushes in a row while the target is hidden before a grasp, 0: off (default HIDDEN_PUSHES); enclosed_grasp: a
    target inside a vessel is grasped as a spent budget does (default off); unsure_grasp: off = while a tracked
    target's track is in doubt (PolicyObservation.unsure), push instead of grasping until the push budget is spent
    (default on: grasp as Q_g says). ValueError naming the option for a value out of range."""

    threshold: float
    push_budget: int = 0
    rules: tuple[str, ...] = ()
    q_window: bool = True
    forced_grasp: bool = True
    refused_push: bool = True
    min_target_cells: int = MIN_VISIBLE_CELLS
    hidden_pushes: int = HIDDEN_PUSHES
    enclosed_grasp: bool = False
    unsure_grasp: bool = True

    def __post_init__(self) -> None:
        if math.isnan(self.threshold):
            raise ValueError("option grasp_threshold: the grasp threshold must be a number, got nan")
        if self.push_budget < 0:
            raise ValueError(f"option push_budget: the push budget must be >= 0 (0 = none), got {self.push_budget}")
        if self.min_target_cells < 1:
            raise ValueError(f"option min_target_cells: min_target_cells must be >= 1, got {self.min_target_cells}")
        if self.hidden_pushes < 0:
            raise ValueError(f"option hidden_pushes: hidden_pushes must be >= 0 (0 = off), got {self.hidden_pushes}")

    @classmethod
    def from_model(cls, metadata: Mapping[str, Any], overrides: Mapping[str, Any]) -> LearnedConfig:
        """The settings of a grasp model's `metadata` under the option values `overrides` (PolicyOptions.overrides,
        by option name; None or absent: unset). ValueError naming the option for a bad value, an undeclared option,
        or a model without a threshold when none is given."""
        value = {name: option(name).parse(overrides.get(name)) for name in (
            "grasp_threshold", "push_budget", "q_window", "forced_grasp", "refused_push", "min_target_cells",
            "hidden_pushes", "enclosed_grasp", "unsure_grasp")}
        threshold = value["grasp_threshold"]
        budget = value["push_budget"]
        if budget is None:
            stored = metadata_thresholds(metadata).get("push_budget", 0)
            try:
                budget = int(stored)
            except (TypeError, ValueError):
                raise ValueError(f"option push_budget: the model's thresholds.push_budget must be an integer, got "
                                 f"{stored!r}") from None
        return cls(
            threshold=float(threshold) if threshold is not None else threshold_from_metadata(metadata),
            push_budget=budget,
            rules=tuple(resolved_rules(model_rules(metadata), overrides)),
            q_window=value["q_window"] is not False,  # unset: on
            forced_grasp=value["forced_grasp"] is not False,  # unset: on
            refused_push=value["refused_push"] is not False,  # unset: on
            min_target_cells=MIN_VISIBLE_CELLS if value["min_target_cells"] is None else value["min_target_cells"],
            hidden_pushes=HIDDEN_PUSHES if value["hidden_pushes"] is None else value["hidden_pushes"],
            enclosed_grasp=value["enclosed_grasp"] is True,  # unset: off
            unsure_grasp=value["unsure_grasp"] is not False,  # unset: on
        )


class LearnedPolicy(PolicyBase):
    """Grasp and push nets + rule pipeline + decision rule (module docstring). `config` holds the settings (a
    LearnedConfig), `rules` is the pipeline of its rule list."""

    name = "learned"

    def __init__(self, opts: PolicyOptions) -> None:
        super().__init__(opts)
        grasp, push = resolve_models(opts.models, need_push=True)
        self.model_paths = (grasp, push)
        self.nets = load_nets(grasp, push, opts.device)
        self.config = LearnedConfig.from_model(self.nets.metadata["grasp"], opts.overrides)
        self.rules = make_pipeline(self.config.rules, self.geometry)
        self.pushes_in_row = 0
        self.last: Decision | None = None
        self.last_note = ""
        self.last_timings: dict[str, float] = {}  # seconds per stage of the last act(): perceive, nets, rule:*, decide

    @property
    def threshold(self) -> float:
        """The grasp threshold (the Policy attribute the evaluation, infer and the policy node show)."""
        return self.config.threshold

    @property
    def push_budget(self) -> int:
        return self.config.push_budget

    @property
    def hidden_pushes(self) -> int:
        return self.config.hidden_pushes

    def _q_maps(self, hm: Any, target: np.ndarray, ctx: RuleContext) -> dict[str, np.ndarray]:
        """{"grasp", "push"}: (R, H, W) float32 maps, full or (q_window) exact on each region's bounding box (grown by
        the reach of that primitive's rules, WINDOW_MARGIN_CELLS where a filter's reach is unknown) and -inf
        elsewhere (an empty region: all -inf)."""
        if not self.config.q_window:
            return self.nets.q_maps(hm, target)
        shape = (self.nets.num_rotations, *target.shape)
        windows = {}
        for role, region in (("grasp", ctx.grasp_region), ("push", ctx.push_region)):
            reach = [r.reach() for r in self.rules.rules if r.primitive == role]
            win = target_window(region, max((WINDOW_MARGIN_CELLS if n is None else n for n in reach), default=0))
            if win is not None:
                windows[role] = win
        q = self.nets.q_windows(hm, target, windows) if windows else {}
        out = {}
        for role in ("grasp", "push"):
            full = np.full(shape, -np.inf, dtype=np.float32)
            if role in q:
                r0, r1, c0, c1 = windows[role]
                full[:, r0:r1, c0:c1] = q[role]
            out[role] = full
        return out

    def reset(self, seed: int | None = None) -> None:
        super().reset(seed)
        self.rules.reset()
        self.pushes_in_row = 0
        self.last, self.last_note = None, ""

    def act(self, obs: Any) -> Decision:
        t0 = time.perf_counter()
        hm = obs.heightmap
        goal = goal_of(obs, self.config.min_target_cells)
        target, visible = goal.mask, goal.visible
        ctx = RuleContext(hm, target, visible, *regions(target, hm))
        self.rules.observe(self.last, ctx)
        t1 = time.perf_counter()
        q = self._q_maps(hm, target, ctx)
        q["push"] = without_futile(q["push"], hm, getattr(obs, "search", None), ctx.push_region)
        t2 = time.perf_counter()
        outcome = self.rules.apply(q, ctx)
        t3 = time.perf_counter()
        self._q = outcome.shown
        enclosed = self.config.enclosed_grasp and visible and target_enclosed(hm, target)
        spent = 0 < self.config.push_budget <= self.pushes_in_row or enclosed
        refused = self.config.refused_push and outcome.vetoed["push"]  # no push passes the push rules
        force, self.last_note = (Force.GRASP if spent or refused else Force.NONE), ""
        if refused:
            self.last_note = "every push is refused by the push rules: grasp"
        elif enclosed:
            self.last_note = "target inside a vessel: grasp"
        if outcome.push_instead and not (spent or refused):
            force, self.last_note = Force.PUSH, outcome.note
        if not visible and self.pushes_in_row < self.config.hidden_pushes:
            force = Force.PUSH
        elif visible and not self.config.unsure_grasp and getattr(obs, "unsure", False) and not (spent or refused):
            force, self.last_note = Force.PUSH, "target track unsure: push"
        q_grasp = outcome.q["grasp"]
        if (spent or refused) and self.config.forced_grasp and outcome.vetoed["grasp"]:
            q_grasp, level = self.rules.forced_grasp(q_grasp, ctx)
            why = ("every push is refused by the push rules" if refused else
                   "target inside a vessel" if enclosed else "push budget spent")
            self.last_note = (f"{why}: grasp passing fallback test {level + 1} of the grasp rules" if level is not None
                              else f"{why}: no grasp passes the grasp rules' fallback tests: Q_g's best")
        d = decide(q_grasp, outcome.q["push"], target, hm, self.prims, decision_threshold(force, self.threshold),
                   push_mask=ctx.push_region, grasp_mask=ctx.grasp_region)  # the regions the rules saw
        if d.primitive == "grasp" and outcome.proposed["grasp"] and not self.last_note:
            self.last_note = ("no grasp among Q_g's best passes the checks: grasp proposed by "
                              + ", ".join(outcome.proposed["grasp"]))
        if not visible:  # e.g. "target hidden: searching where last seen (x, y): push"
            self.last_note = f"{goal.note}: {d.primitive}" + (f" ({self.last_note})" if self.last_note else "")
        self.pushes_in_row = self.pushes_in_row + 1 if d.primitive == "push" else 0
        self.last = d
        rules = {(name if name == "rerank" else f"rule:{name}"): s for name, s in self.rules.timings.items()}
        self.last_timings = {"perceive": t1 - t0, "nets": t2 - t1, **rules, "decide": time.perf_counter() - t3}
        return d


def without_futile(q_push: np.ndarray, hm: Any, search: Any, region: np.ndarray) -> np.ndarray:
    """The (R, H, W) push map with -inf where a push would repeat one the episode's target memory found futile
    (`search.futile_pushes`: same rotation, start within `search.futile_radius_m`; the cells the episode refuses);
    unchanged without a memory or futile pushes, or when that would leave no finite value in `region` ((H, W) bool)."""
    pushes = getattr(search, "futile_pushes", ())
    if not pushes:
        return q_push
    out = suppress_near(q_push, hm, [((r,), x, y) for r, x, y in pushes], float(search.futile_radius_m))
    return out if np.isfinite(out[:, region]).any() else q_push
