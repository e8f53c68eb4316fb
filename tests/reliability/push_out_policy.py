"""A scripted policy for the target_lost probe: its first action pushes the target of EDGE_SCENE out of the workspace,
every later one pushes on empty table far from it. Registered for one policy node of the probe through a generated
entry point (`write_plugin`: a dist-info folder on the node's PYTHONPATH, the plugin mechanism of docs/PLUGINS.md),
never installed.

The first push runs along +x from EDGE_X - 0.05 m: its end is clipped to the workspace and the fingers carry the
cube beyond the +x border (as pg_learning/test/test_target_lost.py's PushOut)."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

EDGE_X = 0.19  # m: the target cube's centre, 5 heightmap cells from the workspace's +x border (0.224 m)
POLICY_NAME = "reliability-push-out"
ENTRY = f"{POLICY_NAME} = reliability.push_out_policy:PushOutPolicy"
EDGE_SCENE = f"""name: reliability/target_edge
target: green
family: reliability
objects:
- name: target
  shape: cube
  color: green
  pose: [{EDGE_X}, 0.0, 0.0235, 0.0, 0.0, 0.0]
  target: true
- name: other
  shape: rect
  color: blue
  pose: [-0.1, 0.1, 0.0235, 0.0, 0.0, 1.0]
"""


class PushOutPolicy:
    """The Policy protocol (docs/PLUGINS.md): push the target out first, then push far away on empty table."""

    name = POLICY_NAME
    last_note = ""

    def __init__(self, _opts: Any = None) -> None:
        self.n = 0

    def reset(self, seed: int | None = None) -> None:
        self.n = 0

    def act(self, obs: Any) -> Any:
        from pg_core.heightmap import rotation_yaw
        from pg_policy.decision.decision import Decision

        self.n += 1
        if self.n == 1:
            self.last_note = "push the target out along +x"
            return Decision("push", 0, 112, 182, math.nan, 0.0, EDGE_X - 0.05, 0.0, 0.01, math.nan)
        r = self.n % 16
        self.last_note = "push on empty table"
        return Decision("push", r, 37, 37, math.nan, rotation_yaw(r, 16), -0.15, -0.15, 0.005, math.nan)

    def q_maps(self) -> dict[str, Any]:
        return {}


def write_plugin(folder: Path) -> Path:
    """A folder that, on a process's PYTHONPATH (with the repository's tests/ folder), registers POLICY_NAME in the
    entry-point group pushgrasp.policies; returns it."""
    info = folder / "pg_reliability_push_out-0.0.0.dist-info"
    info.mkdir(parents=True, exist_ok=True)
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: pg-reliability-push-out\nVersion: 0.0.0\n")
    (info / "entry_points.txt").write_text(f"[pushgrasp.policies]\n{ENTRY}\n")
    return folder
