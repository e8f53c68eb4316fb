"""The `learned` policy: the grasp and push nets, the model's test-time rules, and the paper's decision rule.

Per decision (the paper's loop at test time):
1. perceive: the target mask (goal-agnostic: every object cell while the target is not visible) and the regions;
2. Q maps: both nets over the 16 rotations (pg_policy.models.inference);
3. rules: the model's rule pipeline adjusts the maps (pg_policy.decision.rules; first told what the last action did);
4. decide: grasp if the masked max Q_g exceeds the threshold, else push (pg_policy.decision.decision.decide); a push
   budget B > 0 grasps after B pushes in a row whatever Q_g says (as the paper's push stage does in training), and a
   vetoing grasp rule pushes instead within the budget.
The threshold and budget come from the grasp model's metadata (thresholds.grasp_q, push_budget), the rule list from
its `rules` (or the switches of older models); PolicyOptions overrides any of them (pg_policy.policies.options).
"""

from __future__ import annotations

import math
import time
from typing import Any

from pg_policy.decision.decision import Decision, decide, grasp_region, push_region
from pg_policy.decision.rules.registry import make_pipeline, model_rules
from pg_policy.decision.rules.rule import RuleContext
from pg_policy.policies.model_files import load_nets, metadata_thresholds, resolve_models, threshold_from_metadata
from pg_policy.policies.options import resolved_rules
from pg_policy.policies.policy import PolicyBase, PolicyOptions, goal_or_all


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
        self.pushes_in_row = 0
        self.last: Decision | None = None
        self.last_note = ""
        self.last_timings: dict[str, float] = {}  # seconds per stage of the last act(): perceive, nets, rule:*, decide

    def reset(self, seed: int | None = None) -> None:
        super().reset(seed)
        self.rules.reset()
        self.pushes_in_row = 0
        self.last, self.last_note = None, ""

    def act(self, obs: Any) -> Decision:
        t0 = time.perf_counter()
        hm = obs.heightmap
        target, visible = goal_or_all(obs)
        ctx = RuleContext(hm, target, visible, grasp_region(target, hm.resolution), push_region(target, hm.resolution))
        self.rules.observe(self.last, ctx)
        t1 = time.perf_counter()
        q = self.nets.q_maps(hm, target)
        t2 = time.perf_counter()
        outcome = self.rules.apply(q, ctx)
        t3 = time.perf_counter()
        self._q = outcome.shown
        spent = 0 < self.push_budget <= self.pushes_in_row
        threshold, self.last_note = (-math.inf if spent else self.threshold), ""
        if outcome.push_instead and not spent:
            threshold, self.last_note = math.inf, outcome.note
        d = decide(outcome.q["grasp"], outcome.q["push"], target, hm, self.prims, threshold,
                   push_mask=ctx.push_region, grasp_mask=ctx.grasp_region)  # the regions the rules saw
        self.pushes_in_row = self.pushes_in_row + 1 if d.primitive == "push" else 0
        self.last = d
        rules = {(name if name == "rerank" else f"rule:{name}"): s for name, s in self.rules.timings.items()}
        self.last_timings = {"perceive": t1 - t0, "nets": t2 - t1, **rules, "decide": time.perf_counter() - t3}
        return d
