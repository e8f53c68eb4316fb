"""Median act() latency (ms) of the shipped `lite` policy with and without the jaw grasp check, on the first
observation of each packed scene (seed 1,000,000), two rounds, 2 torch threads.
Run: `.venv/bin/python results/experiments/grasp_check/act_time.py` (after `source scripts/ros_env.sh`)."""

import statistics
import time

import torch

from pg_policy.evaluate import expand_scenes
from pg_policy.policies import PolicyOptions, make_policy
from pg_policy.sim_env import SimEnv


def main() -> None:
    torch.set_num_threads(2)
    env = SimEnv()
    observations = [env.reset(name, seed=1000000) for name in expand_scenes(["packed"])]
    env.close()
    for check in ("none", "jaw", "none", "jaw"):
        policy = make_policy("lite", PolicyOptions(grasp_check=check))
        times = []
        for obs in observations:
            policy.reset(0)
            t0 = time.perf_counter()
            policy.act(obs)
            times.append(time.perf_counter() - t0)
        print(f"{check}: median act() {1000 * statistics.median(times):.1f} ms over {len(times)} decisions")


if __name__ == "__main__":
    main()
