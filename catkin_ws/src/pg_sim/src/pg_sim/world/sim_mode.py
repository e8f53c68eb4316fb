"""Simulation modes: how the simulator trades step-by-step fidelity for speed (no ROS).

- ``fast`` (the default): the table collides as a separate static body, not as a link of the robot (objects
  resting on it do not join the moving robot's contact island: about half the cost per physics step), and the
  arms cross free space kinematically (pg_sim.world.transit): the joint-space moves of a primitive (home to above
  the pre-pose, and back home) are collision-checked teleports when they keep their clearance from every object,
  followed by physics until the objects are at rest (at most the move's own duration). Outcomes match ``faithful``
  statistically, not bit for bit (the paired protocol comparison in docs/RESULTS.md).
- ``faithful``: every motion is simulated step by step, with the table as the robot's link (the primitives'
  tests, and the reference the fast mode is compared with).
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class SimMode:
    name: str
    static_table: bool  # the table's collision is a separate static body (the robot's table link stays visual)
    kinematic_transit: bool  # free-space joint moves of a primitive are teleported when clear of every object
    transit_clearance: float = 0.02  # m: every arm link keeps at least this from every object along a teleport
    transit_step: float = 0.05  # rad: largest joint change between two collision-checked samples of a teleport


SIM_MODES: dict[str, SimMode] = {
    "fast": SimMode("fast", static_table=True, kinematic_transit=True),
    "faithful": SimMode("faithful", static_table=False, kinematic_transit=False),
}
DEFAULT_SIM_MODE = "fast"


def get_sim_mode(mode: str | SimMode) -> SimMode:
    """The registered mode of that name (a SimMode passes through); raises ValueError naming the known modes."""
    if isinstance(mode, SimMode):
        return mode
    if mode not in SIM_MODES:
        raise ValueError(f"unknown simulation mode {mode!r} (known: {', '.join(SIM_MODES)})")
    return SIM_MODES[mode]
