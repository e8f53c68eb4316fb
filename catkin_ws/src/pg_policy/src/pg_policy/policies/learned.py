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
   tests (option forced_grasp, on by default; RulePipeline.forced_grasp), else to Q_g's argmax.
The threshold and budget come from the grasp model's metadata (thresholds.grasp_q, push_budget), the rule list from
its `rules` (or the switches of older models); PolicyOptions overrides any of them (pg_policy.policies.options).
"""

from __future__ import annotations

import math
import time
from typing import Any

import numpy as np

from pg_core.target_mask import MIN_VISIBLE_CELLS
from pg_policy.decision.decision import Decision, decide, regions
from pg_policy.decision.rules.failed_grasps import suppress_near
from pg_policy.decision.rules.registry import make_pipeline, model_rules
from pg_policy.decision.rules.rule import RuleContext
from pg_policy.models.inference import target_window
from pg_policy.policies.model_files import load_nets, metadata_thresholds, resolve_models, threshold_from_metadata
from pg_policy.policies.options import HIDDEN_PUSHES, resolved_rules
from pg_policy.policies.policy import PolicyBase, PolicyOptions, goal_of

# Cells of Q computed beyond a region: each rule's `reach` (the grasp filter's k x k squares read (k - 1) / 2 cells
# around a cell; the shipped min3 reads 1), this many for a filter rule whose reach is unknown. A primitive without
# filter rules needs its region only.
WINDOW_MARGIN_CELLS = 4


class LearnedPolicy(PolicyBase):
    """Grasp and push nets + rule pipeline + decision rule (module docstring). `rules` is the pipeline in use."""

    name = "learned"

    def __init__(self, opts: PolicyOptions) -> None:
        super().__init__(opts)
        grasp, push = resolve_models(opts.models, need_push=True)
        self.model_paths = (grasp, push)
        self.nets = load_nets(grasp, push, opts.device)
        meta = self.nets.metadata["grasp"]
        threshold = opts.get("grasp_threshold")
        self.threshold = float(threshold) if threshold is not None else threshold_from_metadata(meta)
        budget = opts.get("push_budget")
        budget = metadata_thresholds(meta).get("push_budget", 0) if budget is None else budget
        if int(budget) < 0:
            raise ValueError(f"push budget must be >= 0 (0 = none), got {budget}")
        self.push_budget = int(budget)
        self.rules = make_pipeline(resolved_rules(model_rules(meta), opts.overrides), self.geometry)
        self.q_window = opts.get("q_window") is not False  # unset: on
        self.forced_fallback = opts.get("forced_grasp") is not False  # unset: on
        min_cells = opts.get("min_target_cells")
        self.min_target_cells = MIN_VISIBLE_CELLS if min_cells is None else int(min_cells)
        if self.min_target_cells < 1:
            raise ValueError(f"min_target_cells must be >= 1, got {self.min_target_cells}")
        hidden = opts.get("hidden_pushes")
        self.hidden_pushes = HIDDEN_PUSHES if hidden is None else int(hidden)
        if self.hidden_pushes < 0:
            raise ValueError(f"hidden_pushes must be >= 0 (0 = off), got {self.hidden_pushes}")
        self.pushes_in_row = 0
        self.last: Decision | None = None
        self.last_note = ""
        self.last_timings: dict[str, float] = {}  # seconds per stage of the last act(): perceive, nets, rule:*, decide

    def _q_maps(self, hm: Any, target: np.ndarray, ctx: RuleContext) -> dict[str, np.ndarray]:
        """{"grasp", "push"}: (R, H, W) float32 maps, full or (q_window) exact on each region's bounding box (grown by
        the reach of that primitive's rules, WINDOW_MARGIN_CELLS where a filter's reach is unknown) and -inf
        elsewhere (an empty region: all -inf)."""
        if not self.q_window:
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
        goal = goal_of(obs, self.min_target_cells)
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
        spent = 0 < self.push_budget <= self.pushes_in_row
        threshold, self.last_note = (-math.inf if spent else self.threshold), ""
        if outcome.push_instead and not spent:
            threshold, self.last_note = math.inf, outcome.note
        if not visible and self.pushes_in_row < self.hidden_pushes:
            threshold = math.inf
        q_grasp = outcome.q["grasp"]
        if spent and self.forced_fallback and outcome.vetoed["grasp"]:
            q_grasp, level = self.rules.forced_grasp(q_grasp, ctx)
            if level is not None:
                self.last_note = f"push budget spent: grasp passing fallback test {level + 1} of the grasp rules"
        d = decide(q_grasp, outcome.q["push"], target, hm, self.prims, threshold,
                   push_mask=ctx.push_region, grasp_mask=ctx.grasp_region)  # the regions the rules saw
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
