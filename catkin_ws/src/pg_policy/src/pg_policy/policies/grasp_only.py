"""The `grasp-only` baseline: a learned grasp net alone, always grasping at the best filtered Q_g."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from pg_policy.decision.decision import Decision, masked_argmax, regions
from pg_policy.decision.rules.registry import make_pipeline, model_rules
from pg_policy.decision.rules.rule import RuleContext
from pg_policy.policies.model_files import load_nets, resolve_models
from pg_policy.policies.options import resolved_rules
from pg_policy.policies.policy import PolicyBase, PolicyOptions, goal_or_all


class GraspOnlyPolicy(PolicyBase):
    """Always grasps at the argmax of Q_g over the target mask (all objects when the target is not visible), Q_g
    passed through the "filter" rules of the model's rule list (e.g. grasp_filter:min3); no other rule applies."""

    name = "grasp-only"

    def __init__(self, opts: PolicyOptions) -> None:
        super().__init__(opts)
        grasp, _ = resolve_models(opts.models, need_push=False)
        self.model_paths: tuple[Path, ...] = (grasp,)
        self.nets = load_nets(grasp, None, opts.device)
        rules = make_pipeline(resolved_rules(model_rules(self.nets.metadata["grasp"]), opts.overrides), self.geometry)
        self.filters = [r for r in rules.rules if r.primitive == "grasp" and r.rule_kind().shown]

    def act(self, obs: Any) -> Decision:
        hm = obs.heightmap
        mask, visible = goal_or_all(obs)
        q = self.nets.q_maps(hm, mask, nets=("grasp",))["grasp"]
        ctx = RuleContext(hm, mask, visible, *regions(mask, hm))
        for f in self.filters:
            q = f.adjust(q, ctx)
        self._q = {"grasp": q}
        region = ctx.grasp_region  # the target's valid cells
        r, row, col, value = masked_argmax(q, region if region.any() else mask)
        return self.decision(hm, "grasp", r, row, col, value, value)
