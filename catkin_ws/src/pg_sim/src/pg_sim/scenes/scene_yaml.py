"""The YAML loader of scene files: PyYAML's safe loader, reading exponent floats as YAML 1.2 does.

PyYAML implements YAML 1.1, where a float needs a dot and a signed exponent: ``1e6`` and ``2.5e3`` are strings
there, ``1.0e+6`` a float. Scene authors write numbers as YAML 1.2 (and JSON, and Python) read them, so
`SceneLoader` also reads ``[-+]digits[.digits](e|E)[-+]digits`` as a float. Everything else is SafeLoader's.
`check_friction` validates an object's ``friction`` key.
"""

from __future__ import annotations

import math
import re
from typing import Any

import yaml

_EXPONENT_FLOAT = re.compile(r"^[-+]?(?:[0-9][0-9_]*(?:\.[0-9_]*)?|\.[0-9_]+)[eE][-+]?[0-9]+$")


class SceneLoader(yaml.SafeLoader):
    """yaml.SafeLoader with YAML 1.2 exponent floats (module docstring)."""


SceneLoader.add_implicit_resolver("tag:yaml.org,2002:float", _EXPONENT_FLOAT, list("-+0123456789."))


MAX_FRICTION = 2.0  # largest lateral friction coefficient a scene object may be given


def check_friction(value: Any) -> float:
    """The lateral friction coefficient ``value`` as a float; raises ValueError unless it is a finite number in
    (0, MAX_FRICTION]."""
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value) \
            or not 0.0 < value <= MAX_FRICTION:
        raise ValueError(f"friction must be a lateral friction coefficient in (0, {MAX_FRICTION}], "
                         f"got {str(value)[:40]}")
    return float(value)
