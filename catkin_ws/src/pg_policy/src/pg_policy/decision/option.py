"""A user-facing decision option, declared once: its name, type, help and the rule it switches.

The policies' option table (pg_policy.policies.options) is built from these declarations; from it come the CLI flags
(`--grasp-check`), the policy node's private parameters (`~grasp_check`) and the launch arguments
(`grasp_check:=`). A model option (grasp threshold, push budget, rule list, rule switches) is exported in the model's
metadata, so an unset one leaves the model's value; a policy option (`default` set) is not in the model, so an unset
one takes the policy's default.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

TYPES = ("float", "int", "str", "switch")  # "switch": on | off (launch and ROS parameters also take true | false)
AUTO = "auto"  # the launch files' and parameters' word for "unset: the model's own"


@dataclass(frozen=True)
class PolicyOption:
    """name: snake_case (the ROS parameter and launch argument; the CLI flag is --name-with-dashes); type: one of
    TYPES; help: one sentence for --help, the launch file's doc= and docs; choices / metavar: for the CLI; rule:
    the test-time rule (pg_policy.decision.rules) this option switches, None for a plain option; off: the value
    that removes the rule from the list ("switch" options: off); default: None for a model option (its unset value
    is the model's own), else the policy's value when unset, as --help and the launch files show it (e.g. "25")."""

    name: str
    type: str
    help: str
    choices: tuple[str, ...] | None = None
    metavar: str | None = None
    rule: str | None = None
    off: Any = None
    default: str | None = None

    def __post_init__(self) -> None:
        if self.type not in TYPES:
            raise ValueError(f"option {self.name}: type must be one of {TYPES}, got {self.type!r}")

    @property
    def in_model(self) -> bool:
        """Whether the exported model carries this option's value (pushgrasp export takes it)."""
        return self.default is None

    @property
    def flag(self) -> str:
        return "--" + self.name.replace("_", "-")

    def parse(self, value: Any) -> Any:
        """The option's value from a CLI string, a ROS parameter or a Python value; None for None, "" or "auto".
        Raises ValueError naming the option for a value of the wrong type or outside `choices`."""
        if value is None or (isinstance(value, str) and value.strip().lower() in ("", AUTO)):
            return None
        try:
            if self.type == "switch":
                if isinstance(value, bool):
                    return value
                word = str(value).strip().lower()
                if word not in ("on", "off", "true", "false"):
                    raise ValueError
                return word in ("on", "true")
            out = {"float": float, "int": int, "str": str}[self.type](value)
        except (TypeError, ValueError):
            raise ValueError(f"option {self.name}: expected {self.type}{' (on/off)' if self.type == 'switch' else ''}"
                             f", got {value!r}") from None
        if self.choices is not None and out not in self.choices:
            raise ValueError(f"option {self.name}: expected one of {', '.join(self.choices)}, got {value!r}")
        return out

    def rule_spec(self, value: Any) -> str | None:
        """The rule list entry that the (parsed, not None) `value` asks for: None removes the rule."""
        if self.type == "switch":
            return self.rule if value else None
        if value == self.off:
            return None
        return f"{self.rule}:{value:g}" if isinstance(value, float) else f"{self.rule}:{value}"
