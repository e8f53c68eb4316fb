"""Limits on what a scene file may ask for: number of objects, object dimensions, how far from the workspace.

They bound the work a scene costs (a reset and a render grow with the objects) and refuse scenes that cannot be a
table-top scene (a 1 km cube, a 1 nm cube, an object 1e6 m away). Every loaded scene is checked with them, from the
command line and from the sim node alike; the sim node takes its values from its parameters (sim_node docstring).
Each check raises ValueError naming the field and the value; pg_sim.scenes.scene adds the file, object and line.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from pg_core.geometry import Workspace
from pg_sim.scenes.short_repr import short

MAX_OBJECTS = 40          # objects in one scene (as many as the largest generated scene)
MAX_OBJECT_SIZE = 0.3     # m: largest bounding-box extent of one object (the workspace is 0.448 m wide)
MIN_OBJECT_SIZE = 0.002   # m: smallest bounding-box extent (the thinnest catalogue objects are 3 mm)
MAX_POSE_DISTANCE = 0.5   # m: how far outside the workspace box an object's position may be

@dataclass(frozen=True)
class SceneLimits:
    """Scene limits (see the module docstring); sizes and distances in metres. ``workspace`` None: the workspace of
    pg_description's workspace.yaml. Raises ValueError on construction for limits that contradict each other."""

    max_objects: int = MAX_OBJECTS
    max_object_size: float = MAX_OBJECT_SIZE
    min_object_size: float = MIN_OBJECT_SIZE
    max_pose_distance: float = MAX_POSE_DISTANCE
    workspace: Workspace | None = None

    def __post_init__(self) -> None:
        if self.max_objects < 1:
            raise ValueError(f"max_objects must be at least 1, got {self.max_objects}")
        if not 0.0 < self.min_object_size <= self.max_object_size:
            raise ValueError(f"need 0 < min_object_size <= max_object_size, got {self.min_object_size} and "
                             f"{self.max_object_size}")
        if not self.max_pose_distance >= 0.0:
            raise ValueError(f"max_pose_distance must be >= 0 m, got {self.max_pose_distance}")

    def box(self) -> Workspace:
        if self.workspace is not None:
            return self.workspace
        from pg_core.geometry import load

        return load().workspace

    def check_count(self, count: int) -> None:
        """Raises ValueError when a scene has more than ``max_objects`` objects."""
        if count > self.max_objects:
            raise ValueError(f"objects: {count} objects, at most {self.max_objects} allowed (max_objects)")

    def check_extents(self, extents: Sequence[float], field: str) -> None:
        """Raises ValueError when a bounding-box extent (m) lies outside [min_object_size, max_object_size]."""
        big, small = max(extents), min(extents)
        where = f"{field} {short([float(v) for v in extents])}"
        if big > self.max_object_size:
            raise ValueError(f"{where}: extent {big:g} m is larger than max_object_size {self.max_object_size:g} m")
        if small < self.min_object_size:
            raise ValueError(f"{where}: extent {small:g} m is smaller than min_object_size "
                             f"{self.min_object_size:g} m")

    def check_position(self, xyz: Sequence[float]) -> None:
        """Raises ValueError when ``xyz`` (m, `world`) is more than ``max_pose_distance`` outside the workspace box."""
        bounds = self.box().bounds
        p = np.asarray(xyz, dtype=np.float64)
        outside = float(np.linalg.norm(np.maximum(bounds[:, 0] - p, 0.0) + np.maximum(p - bounds[:, 1], 0.0)))
        if outside > self.max_pose_distance:
            raise ValueError(f"pose position {short([float(v) for v in xyz])}: {outside:g} m outside the workspace, "
                             f"at most max_pose_distance {self.max_pose_distance:g} m")


DEFAULT_LIMITS = SceneLimits()
