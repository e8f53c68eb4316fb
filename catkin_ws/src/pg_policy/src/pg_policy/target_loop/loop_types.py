"""The target loop's types (pg_policy.target_loop.target_loop): its errors, what its heightmap source and primitive
executor give it, what it records per action and per call, what the policy is given, and the target helpers that
turn a request's target into a spec and a name."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Protocol

import numpy as np

from pg_core.heightmap import Heightmap
from pg_core.palette import normalize_name
from pg_core.target_mask import hsv_window, target_mask
from pg_policy.decision.decision import Decision
from pg_policy.perception.target_memory import TargetSearch
from pg_policy.target_loop.target_spec import ColourTarget, MaskTarget, PointTarget, TargetSpec


class LoopError(RuntimeError):
    """A call that cannot start or go on: unknown colour, target not visible, no heightmap, ... (message says)."""


class NoHeightmap(LoopError, TimeoutError):
    """No heightmap newer than the requested stamp arrived within the wait."""


class TargetRefused(LoopError):
    """A point or mask target that the call's first heightmap refuses (message: the spec's ValueError, naming
    PointTarget / MaskTarget); raised before anything moves."""


class SceneReset(LoopError):
    """The scene token changed during a call: what the call saw and did belongs to a scene that is gone."""


@dataclass(frozen=True)
class StampedHeightmap:
    heightmap: Heightmap
    stamp: float  # ROS time (s) of the source point cloud


@dataclass(frozen=True)
class Execution:
    """Outcome of one primitive. success: it ran to its end; grasped: grasp only, fingers not closed after the lift;
    arm: the arm that moved; duration: ROS seconds; end_stamp: ROS time when it finished."""

    success: bool
    grasped: bool
    arm: str
    message: str
    duration: float
    end_stamp: float


class HeightmapSource(Protocol):
    def wait_after(self, stamp: float, timeout_s: float) -> StampedHeightmap:
        """The latest heightmap stamped strictly after `stamp`; raises NoHeightmap after timeout_s wall seconds."""
        ...


class PrimitiveExecutor(Protocol):
    def execute(self, decision: Decision, timeout_s: float) -> Execution:
        """Run the decision's primitive; raises LoopError when the executor cannot be reached at all."""
        ...


@dataclass
class ActionRecord:
    """One decision and, when executed, its outcome (the content of a pg_msgs/Decision)."""

    episode: int
    index: int
    target: str
    policy: str
    decision: Decision
    heightmap_stamp: float
    decided_stamp: float
    target_pixels: int
    grasp_threshold: float = math.nan
    execution: Execution | None = None
    target_grasped: bool = False
    note: str = ""  # why the policy took the decision (its last_note), e.g. "target hidden: searching where ..."
    # (H, W) bool target mask the decision was taken on, for point and mask targets (None: colour, `target`'s cells)
    target_mask: np.ndarray | None = field(default=None, repr=False)
    # why the track of a point or mask target was in doubt at the decision ("": sure, or a colour target)
    track_doubt: str = ""


@dataclass
class LoopResult:
    success: bool
    grasps: int = 0
    pushes: int = 0
    duration: float = 0.0  # ROS seconds
    wall_time: float = 0.0
    message: str = ""
    actions: list[ActionRecord] = field(default_factory=list)
    failed_grasps: int = 0
    refused: int = 0  # primitives the controller refused or aborted, and futile pushes not repeated
    termination: str = ""  # why the call ended: a termination of pg_policy.target_loop.episode ("" before it ran)


def check_target(name: str) -> str:
    """Normalised palette colour name; LoopError listing the known colours for an unknown one."""
    try:
        hsv_window(name or "green")
    except ValueError as exc:
        raise LoopError(str(exc)) from None
    return normalize_name(name or "green")


def mask_of(hm: Heightmap, target: str) -> np.ndarray:
    return target_mask(hm.color, hm.valid, target)


def as_spec(target: str | TargetSpec) -> TargetSpec:
    """The spec of a call's target: a colour name ("" = "green") becomes a ColourTarget of the normalised name;
    LoopError for an unknown colour (listing the known ones) or another type."""
    if isinstance(target, str):
        return ColourTarget(check_target(target))
    if isinstance(target, ColourTarget):
        return ColourTarget(check_target(target.name))
    if isinstance(target, PointTarget | MaskTarget):
        return target
    raise LoopError(f"target must be a colour name or a target spec, got {type(target).__name__}")


def target_label(spec: TargetSpec) -> str:
    """The target's name in records and messages: the colour name, "point (x, y)" (world m) or "mask"."""
    if isinstance(spec, ColourTarget):
        return spec.name
    if isinstance(spec, PointTarget):
        return f"point ({spec.x:.3f}, {spec.y:.3f})"
    return "mask"


@dataclass
class PolicyObservation:
    """What pg_policy.policies.registry act on: the heightmap, the target's colour name, within a call the target
    memory (pg_policy.perception.target_memory.TargetSearch; None: no memory, e.g. /pg/infer) and the target's
    (H, W) bool mask when the loop found it otherwise than by colour (a point or a mask request, tracked:
    pg_policy.target_loop.target_spec; None: the policy finds the target by `target`'s colour), and whether that
    mask's track is in doubt (`unsure`: the tracker may follow another object; always False for colours)."""

    heightmap: Heightmap
    target: str
    search: TargetSearch | None = None
    mask: np.ndarray | None = None
    unsure: bool = False
