"""Seeded fuzz requests: /pg/execute_primitive (positions inside, near and far outside the workspace box, non-finite
numbers, frames, arms, yaws, timeouts, primitives) and /pg_sim/reset_scene (shipped names, generated families with
good and bad counts and seeds, garbage names). Each request knows its position in `world` and whether the contract
calls it valid, from the project's geometry config (pg_core.geometry: workspace box, arm base poses)."""

from __future__ import annotations

import math
from dataclasses import dataclass
from random import Random

import numpy as np

from pg_core.geometry import Geometry, pose_matrix

BAD_NUMBERS = (math.nan, math.inf, -math.inf, 1e308, -1e308)
ARMS_OK = ("", "left", "right")
MAX_TIMEOUT_S = 1e6  # a timeout beyond this is treated as a bad value


@dataclass(frozen=True)
class PrimitiveRequest:
    primitive: int
    position: tuple[float, float, float]
    frame: str
    yaw: float
    arm: str
    timeout: float
    world: tuple[float, float, float] | None  # the position in `world`; None when the frame is unknown
    in_box: bool  # the position lies in the workspace box
    valid: bool  # every field as the contract allows (it may still be refused: unreachable)

    @property
    def out_of_bounds(self) -> bool:
        return self.world is not None and not self.in_box


@dataclass(frozen=True)
class ResetRequest:
    scene: str
    num_objects: int
    seed: int
    valid: bool


def _frames(geometry: Geometry) -> dict[str, np.ndarray | None]:
    """Frame name -> 4x4 transform into `world` (None: a frame tf does not know)."""
    frames: dict[str, np.ndarray | None] = {"world": np.eye(4), "/world": np.eye(4)}
    for name, arm in geometry.robot.arms.items():
        frames[f"{name}_base_link"] = pose_matrix(arm.xyz, arm.rpy)
    frames.update({"": None, "nowhere": None, "w\u00f6rld": None})
    return frames


def primitive_request(rng: Random, geometry: Geometry) -> PrimitiveRequest:
    box = geometry.workspace.bounds
    kind = rng.random()
    if kind < 0.45:  # inside, at grasp/push heights
        pos = [rng.uniform(*box[0]), rng.uniform(*box[1]), rng.uniform(0.0, 0.1)]
    elif kind < 0.65:  # around one face of the box, either side
        pos = [rng.uniform(*box[0]), rng.uniform(*box[1]), rng.uniform(0.0, 0.1)]
        axis, side = rng.randrange(3), rng.randrange(2)
        pos[axis] = box[axis][side] + rng.uniform(-0.03, 0.03)
    elif kind < 0.85:  # far outside
        pos = [rng.uniform(-2.0, 2.0), rng.uniform(-2.0, 2.0), rng.uniform(-1.0, 2.0)]
    else:  # non-finite or absurd in one coordinate
        pos = [rng.uniform(*box[0]), rng.uniform(*box[1]), 0.02]
        pos[rng.randrange(3)] = rng.choice(BAD_NUMBERS)
    frames = _frames(geometry)
    names = list(frames)
    frame = rng.choices(names, weights=[70, 5, 8, 7, 3, 4, 3][:len(names)] + [1] * max(0, len(names) - 7))[0]
    t = frames[frame]
    if t is not None and frame.endswith("_base_link") and all(math.isfinite(v) for v in pos):
        local = np.linalg.inv(t) @ np.array([*pos, 1.0])  # the same world point, expressed in that frame
        pos = [float(v) for v in local[:3]]
    world: tuple[float, float, float] | None = None
    if t is not None:
        w = t @ np.array([*pos, 1.0]) if all(math.isfinite(v) for v in pos) else np.array(pos)
        world = (float(w[0]), float(w[1]), float(w[2]))
    in_box = world is not None and all(math.isfinite(v) for v in world) and geometry.workspace.contains(np.array(world))
    arm = rng.choices(["", "left", "right", "middle", "LEFT"], weights=[60, 15, 15, 5, 5])[0]
    yaw = rng.uniform(-math.pi, math.pi) if rng.random() < 0.9 else rng.choice((math.nan, math.inf, 100.0, -7.0))
    r = rng.random()
    timeout = 0.0 if r < 0.6 else rng.uniform(10.0, 60.0) if r < 0.8 else rng.choice((*BAD_NUMBERS, -1.0, 1e-6))
    primitive = rng.choices([1, 0, rng.choice((2, 7, 255))], weights=[50, 45, 5])[0]
    timeout_ok = timeout == 0.0 or (math.isfinite(timeout) and 0.0 < timeout <= MAX_TIMEOUT_S)
    valid = (in_box and t is not None and math.isfinite(yaw) and arm in ARMS_OK and timeout_ok
             and primitive in (0, 1))
    return PrimitiveRequest(primitive, (pos[0], pos[1], pos[2]), frame, yaw, arm, timeout, world, in_box, valid)


def reset_request(rng: Random, shipped: list[str], max_objects: int) -> ResetRequest:
    r = rng.random()
    if r < 0.35:
        return ResetRequest(rng.choice(shipped), 0, 0, True)
    if r < 0.7:
        family = rng.choice(("random", "dense", "novel", "mixed"))
        return ResetRequest(family, rng.randint(1, min(15, max_objects)), 1_000_000 + rng.randrange(10**6), True)
    if r < 0.85:
        if rng.random() < 0.5:
            return ResetRequest("random", rng.choice((-3, 0, max_objects + 1, 1000, 2**31 - 1)), 1_000_000, False)
        return ResetRequest("random", 5, rng.choice((-1, -(2**31))), False)
    garbage = ("../../../../etc/hostname", "packed/../../../../../etc/passwd", "packed/case99", "\u00fc" * 50,
               "x" * 5000, "random-", "random-abc", "/dev/null", " ")
    return ResetRequest(rng.choice(garbage), rng.randint(-2, 5), rng.randint(-2, 5), False)
