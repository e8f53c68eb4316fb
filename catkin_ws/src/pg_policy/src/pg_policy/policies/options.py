"""The policies' options, declared once: the CLI flags, the policy node's private parameters and the launch
arguments all come from OPTIONS.

The general options are declared here; every built-in test-time rule with a user switch declares its own
(pg_policy.decision.rules.rule.Rule.option), so a new rule brings its option with it (a plug-in rule has none: the
rule list, `rules`, switches it). An unset option (None, or
"auto" from ROS) leaves the model's own value. Rule switches edit the model's rule list: a value turns the rule on
(with that argument) or replaces its argument in place, the option's `off` value removes it; `rules` replaces the
whole list first.
"""

from __future__ import annotations

import argparse
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any
from xml.sax.saxutils import quoteattr

from pg_core.target_mask import MIN_VISIBLE_CELLS
from pg_policy.decision.option import AUTO, PolicyOption
from pg_policy.decision.rules.registry import builtin_rule_classes, parse_spec, with_switch

# Pushes in a row while the target is hidden before a goal-agnostic grasp (option hidden_pushes): every neighbour a
# grasp lifts is a failed grasp (DESIGN.md section 8), pushes are not. Chosen on training seeds (docs/RESULTS.md).
HIDDEN_PUSHES = 6

GENERAL = (
    PolicyOption("grasp_threshold", "float", "learned: grasp when the masked max of Q_g over the target exceeds this, "
                 "else push", metavar="Q"),
    PolicyOption("push_budget", "int", "learned: after this many pushes in a row grasp whatever Q_g says; 0: no "
                 "budget", metavar="N"),
    PolicyOption("rules", "str", "learned: the ordered test-time rule list, comma-separated name[:arg] entries (e.g. "
                 "grasp_filter:min3,failed_grasps:0.01,grasp_check:jaw-walls,push_landing,edge_guard); none: no "
                 "rules", metavar="LIST"),
    PolicyOption("min_target_cells", "int", "learned: the target counts as visible (goal-conditioned maps and rules) "
                 "from this many detected cells; fewer: hidden, searched for where it was last seen", metavar="N",
                 default=str(MIN_VISIBLE_CELLS)),
    PolicyOption("hidden_pushes", "int", "learned: while the target is hidden (searched for where it was last seen), "
                 "push instead of grasping a neighbour until this many pushes in a row, then grasp as Q_g says; 0: "
                 "grasp as Q_g says",
                 metavar="N", default=str(HIDDEN_PUSHES)),
    PolicyOption("forced_grasp", "switch", "learned: when the push budget forces a grasp that no candidate passes "
                 "the grasp rules for, grasp the best cell passing their weaker fallback tests; off: Q_g's argmax",
                 default="on"),
    PolicyOption("refused_push", "switch", "learned: when the push rules refuse every push candidate they test (e.g. "
                 "each would carry the target out of the workspace), grasp instead, by the grasp rules' fallback tests "
                 "when none passes them; off: make the best refused push", default="on"),
    PolicyOption("enclosed_grasp", "switch", "learned: grasp at once (as a spent push budget does) when the target "
                 "lies inside a vessel, walls standing over it on every side, instead of pushing the vessel; off: "
                 "the nets and the budget decide", default="off"),
    PolicyOption("unsure_grasp", "switch", "learned: grasp a target named by a point or a mask while its track is "
                 "in doubt (the tracker may follow a look-alike); off: push instead until the push budget is spent "
                 "or the track is sure again", default="on"),
    PolicyOption("q_window", "switch", "learned: compute Q only around the target's grasp and push regions, exactly "
                 "(lite nets; other cells are -inf, so Q map images show the regions); off: the full maps",
                 default="on"),
)
NO_RULES = "none"
MODEL_OWN = "the model's own"


def options() -> tuple[PolicyOption, ...]:
    """Every declared option: GENERAL, then each built-in rule's switch in rule order (plug-in rules have none:
    rule lists switch them)."""
    return GENERAL + tuple(cls.option for cls in builtin_rule_classes().values() if cls.option is not None)


def option(name: str) -> PolicyOption:
    """The declared option `name`; ValueError listing the options for another name."""
    for o in options():
        if o.name == name:
            return o
    raise ValueError(f"unknown policy option {name!r} (known: {', '.join(o.name for o in options())})")


def parse_rule_list(text: str) -> list[str]:
    """The entries of a comma-separated rule list ("none" or "" is the empty list); ValueError for a bad entry."""
    entries = [] if text.strip().lower() in ("", NO_RULES) else [e.strip() for e in text.split(",")]
    for e in entries:
        parse_spec(e)
    return entries


def resolved_rules(model_specs: Sequence[str], overrides: Mapping[str, Any]) -> list[str]:
    """The rule list a policy runs: the model's `model_specs` edited by the option values in `overrides` (module
    docstring). ValueError for an undeclared option, a bad value or a bad rule list."""
    values = {name: option(name).parse(v) for name, v in overrides.items()}
    specs = list(model_specs) if values.get("rules") is None else parse_rule_list(values["rules"])
    for o in options():
        if o.rule is not None and values.get(o.name) is not None:
            specs = with_switch(specs, o.rule, o.rule_spec(values[o.name]))
    return specs


def add_arguments(parser: argparse.ArgumentParser, unset: str | Callable[[PolicyOption], str] = MODEL_OWN,
                  model_only: bool = False) -> None:
    """One flag per declared option (default None; `unset`, a text or a function of the option, says in --help what
    an unset model option means, a policy option shows its own default); model_only: only the options an exported
    model carries (in_model)."""
    for o in options():
        if model_only and not o.in_model:
            continue
        def parse(text: str, o: PolicyOption = o) -> Any:
            try:
                return o.parse(text)
            except ValueError as exc:
                raise argparse.ArgumentTypeError(str(exc)) from None

        metavar = "{on,off}" if o.type == "switch" else ("{" + ",".join(o.choices) + "}" if o.choices else o.metavar)
        parser.add_argument(o.flag, dest=o.name, type=parse, default=None, metavar=metavar,
                            help=f"{o.help} (default: {o.default or (unset if isinstance(unset, str) else unset(o))})")


def from_args(args: argparse.Namespace) -> dict[str, Any]:
    """{option name: value} of the declared options set on the command line."""
    return {o.name: v for o in options() if (v := getattr(args, o.name, None)) is not None}


def from_params(get_param: Callable[[str, Any], Any]) -> dict[str, Any]:
    """{option name: value} of the declared options set as private parameters (`get_param("~name", default)`, e.g.
    rospy.get_param); "auto" means unset. ValueError naming the parameter for a bad value."""
    out = {}
    for o in options():
        raw = get_param(f"~{o.name}", None)
        try:
            value = o.parse(raw)
        except ValueError as exc:
            raise ValueError(f"~{o.name}: {exc}") from None
        if value is not None:
            out[o.name] = value
    return out


BEGIN = "<!-- policy options: generated from pg_policy.policies.options (python -m pg_policy.policies.options) -->"
END = "<!-- end of policy options -->"


def _launch_doc(o: PolicyOption) -> str:
    """The launch argument's doc=: the option's help and what `auto` (unset) means for it."""
    return f"{o.help} ({AUTO}: {o.default or MODEL_OWN})"


def launch_block(kind: str) -> list[str]:
    """The launch file lines for the declared options: "args" (the <arg> declarations of sim.launch, robot.launch
    and pushgrasp_core.launch), "pass" (the include's pass-through <arg>s of sim/robot.launch) or "params" (the
    policy node's <param>s in pushgrasp_core.launch)."""
    types = {"float": "double", "int": "int", "str": "str", "switch": "str"}
    auto = repr(AUTO)
    lines = {
        "args": [f'<arg name="{o.name}" default="{AUTO}" doc={quoteattr(_launch_doc(o))}/>' for o in options()],
        "pass": [f'<arg name="{o.name}" value="$(arg {o.name})"/>' for o in options()],
        "params": [f'<param if="$(eval {o.name} != {auto})" name="{o.name}" type="{types[o.type]}" '
                   f'value="$(arg {o.name})"/>' for o in options()],
    }[kind]
    return [BEGIN, *lines, END]


def write_launch(path: Path) -> bool:
    """Replace every policy-options block of the launch file at `path` (its kind told by the line after BEGIN, kept
    at BEGIN's indentation); True when the file changed. ValueError when the file has no block."""
    text = path.read_text()
    out, changed, i = [], False, 0
    lines = text.split("\n")
    while i < len(lines):
        line = lines[i]
        if line.strip() != BEGIN:
            out.append(line)
            i += 1
            continue
        j = next(k for k in range(i, len(lines)) if lines[k].strip() == END)
        body = [x.strip() for x in lines[i + 1:j]]
        kind = "params" if body and body[0].startswith("<param") else ("pass" if body and "value=" in body[0] else
                                                                        "args")
        indent = line[: len(line) - len(line.lstrip())]
        new = [indent + x for x in launch_block(kind)]
        changed |= new != lines[i:j + 1]
        out += new
        i = j + 1
    if out == lines and BEGIN not in text:
        raise ValueError(f"{path} has no policy-options block ({BEGIN})")
    if changed:
        path.write_text("\n".join(out))
    return changed


def main() -> None:
    """`python -m pg_policy.policies.options [--launch FILE ...]`: print the launch blocks, or rewrite the files'."""
    ap = argparse.ArgumentParser(description=main.__doc__)
    ap.add_argument("--launch", nargs="*", type=Path, default=[], help="launch files whose option blocks to rewrite")
    args = ap.parse_args()
    if not args.launch:
        for kind in ("args", "pass", "params"):
            print("\n".join(launch_block(kind)))
    for path in args.launch:
        print(f"{path}: {'rewritten' if write_launch(path) else 'current'}")


if __name__ == "__main__":
    main()
