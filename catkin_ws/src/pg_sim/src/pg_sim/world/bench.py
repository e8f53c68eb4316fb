"""Simulator speed: median wall time of one primitive in an N-object scene and of one observation.

Primitives target random objects (grasps at the object's centre, pushes starting beside it) so that they make
contact the way policy actions do; refused requests are skipped and counted.
"""

from __future__ import annotations

import os
import time
from dataclasses import dataclass

import numpy as np

from pg_core import heightmap as hm
from pg_core.action_geometry import grasp_z_at, push_z
from pg_sim.world.primitives import PrimitiveExecutor, PrimitiveRefused
from pg_sim.world.random_scene import drop_scene, sample_drops
from pg_sim.world.sim_mode import DEFAULT_SIM_MODE
from pg_sim.world.world import World


@dataclass(frozen=True)
class SimBench:
    mode: str  # simulation mode (pg_sim.world.sim_mode)
    objects: int
    primitive_s: list[float]
    observe_s: list[float]
    refused: int
    sim_s_per_primitive: float

    @property
    def median_primitive_s(self) -> float:
        return float(np.median(self.primitive_s))

    def report(self) -> str:
        prim, obs = np.array(self.primitive_s), np.array(self.observe_s)
        load = os.getloadavg()[0]
        return "\n".join([
            f"[{self.mode}] scene: {self.objects} random objects; primitives timed: {len(prim)} (refused: "
            f"{self.refused}); load {load:.2f} on {os.cpu_count()} CPUs",
            f"primitive wall time  median {np.median(prim):.3f} s  (p10 {np.percentile(prim, 10):.3f}, "
            f"p90 {np.percentile(prim, 90):.3f}); simulated {self.sim_s_per_primitive:.2f} s each "
            f"-> {self.sim_s_per_primitive / np.median(prim):.1f}x real time",
            f"observation (render 640x480 + heightmap) median {np.median(obs) * 1000:.1f} ms "
            f"(p90 {np.percentile(obs, 90) * 1000:.1f} ms) over {len(obs)}",
        ])


def run(objects: int = 20, primitives: int = 20, observations: int = 20, seed: int = 0,
        mode: str = DEFAULT_SIM_MODE) -> SimBench:
    """Time `primitives` primitives and `observations` observations in `mode`; the scenes and the actions' targets
    come from `seed` (each mode starts from the same scene; the scenes then evolve with the mode's physics)."""
    rng = np.random.default_rng(seed)
    prim_s, obs_s, sim_s, refused = [], [], [], 0
    with World(mode=mode) as world:
        ex = PrimitiveExecutor(world, remove_grasped=True)
        drop_scene(world, sample_drops(objects, seed))
        for _ in range(observations):
            t = time.perf_counter()
            world.observe()
            obs_s.append(time.perf_counter() - t)
        while len(prim_s) < primitives:
            if len(world.objects) < objects // 2:
                drop_scene(world, sample_drops(objects, int(rng.integers(1 << 30))))
            obs = world.observe()
            body = list(world.objects)[int(rng.integers(len(world.objects)))]
            x, y = world.object_poses()[body][:2]
            rotations = world.geometry.heightmap.rotations
            yaw = hm.rotation_yaw(int(rng.integers(rotations)), rotations)
            grasp = len(prim_s) % 2 == 0
            if not grasp:
                x, y = x - 0.04 * np.cos(yaw), y - 0.04 * np.sin(yaw)
            r, c = hm.world_to_pixel(x, y, obs.heightmap.bounds, obs.heightmap.resolution)
            r, c = int(np.clip(r, 0, 223)), int(np.clip(c, 0, 223))
            prims = world.geometry.primitives
            if grasp:
                z = grasp_z_at(obs.heightmap, r, c, prims, yaw=yaw)
            else:
                z = push_z(obs.heightmap.height, r, c, prims, yaw=yaw, resolution=obs.heightmap.resolution)
            t, t_sim = time.perf_counter(), world.sim_time
            try:
                (ex.grasp if grasp else ex.push)(float(x), float(y), z, yaw)
            except PrimitiveRefused:
                refused += 1
                continue
            prim_s.append(time.perf_counter() - t)
            sim_s.append(world.sim_time - t_sim)
    return SimBench(world.mode.name, objects, prim_s, obs_s, refused, float(np.mean(sim_s)))
