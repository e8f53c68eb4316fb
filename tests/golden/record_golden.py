"""Record the shipped model's decisions on the first protocol trial of every protocol scene.

Runs trial 0 (seed 1,000,000) of the 16 protocol scenes (DESIGN.md section 8) in the faithful simulation mode (every
motion stepped, as tests/test_golden.py replays two of them) with the shipped `lite` policy, one torch thread as in a
protocol worker, and stores every observation the policy saw (colour, height and validity heightmaps) with the
decision it took: `decisions.npz` (arrays `color_K`, `height_K`, `valid_K` for observation K) and `decisions.json`
(per observation: scene, seed, step, target, resolution, bounds, and the decision). tests/test_golden.py replays the
observations through the policy and demands the same decisions.
Re-record only for a deliberate policy change.

usage: python tests/golden/record_golden.py [--out tests/golden]
"""

from __future__ import annotations

import argparse
import json
from functools import partial
from pathlib import Path
from typing import Any

import numpy as np

SCENES = [*(f"packed/case{i:02d}" for i in range(1, 10)), *(f"household/case{i}" for i in range(11, 15)),
          "random-10", "random-15", "random-20"]
SEED = 1_000_000
THREADS = 1  # torch/OpenCV threads of a protocol worker (`pushgrasp eval --workers 2` on 2 cores): Q maps and with
# them argmax ties depend on the thread count in the last float bits, so the golden replay uses the same


def set_threads(n: int) -> None:
    import cv2
    import torch

    torch.set_num_threads(n)
    cv2.setNumThreads(n)


def main() -> None:
    from pg_learning.environment.sim_env import SimEnv
    from pg_learning.evaluation.runner import EvalPlan, run_fresh
    from pg_policy.policies.registry import make_policy

    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", type=Path, default=Path(__file__).resolve().parent)
    args = ap.parse_args()
    set_threads(THREADS)
    policy = make_policy("lite")
    arrays: dict[str, np.ndarray] = {}
    records: list[dict[str, Any]] = []

    class Recording:
        name = policy.name

        def reset(self, seed: int | None = None) -> None:
            policy.reset(seed)
            self.step = 0

        def act(self, obs: Any) -> Any:
            d = policy.act(obs)
            k = len(records)
            hm = obs.heightmap
            arrays[f"color_{k}"], arrays[f"height_{k}"], arrays[f"valid_{k}"] = hm.color, hm.height, hm.valid
            records.append({"scene": self.scene, "seed": SEED, "step": self.step, "target": obs.target,
                            "resolution": hm.resolution, "bounds": np.asarray(hm.bounds).tolist(),
                            "decision": {"primitive": d.primitive, "rotation": int(d.rotation), "row": int(d.row),
                                         "col": int(d.col), "q": float(d.q), "grasp_q": float(d.grasp_q),
                                         "x": float(d.x), "y": float(d.y), "z": float(d.z), "yaw": float(d.yaw)},
                            "note": str(getattr(policy, "last_note", ""))})
            self.step += 1
            return d

    rec = Recording()
    plan = EvalPlan(scenes=tuple(SCENES), trials=1, seed=SEED)
    for scene in SCENES:
        rec.scene = scene
        t = run_fresh(partial(SimEnv, sim_mode="faithful"), rec, scene, SEED, plan)
        print(f"{scene}: {t.termination}, {t.n_actions} actions", flush=True)
    args.out.mkdir(parents=True, exist_ok=True)
    np.savez_compressed(args.out / "decisions.npz", **arrays)
    (args.out / "decisions.json").write_text(json.dumps(records, indent=1) + "\n")
    print(f"{len(records)} decisions -> {args.out}")


if __name__ == "__main__":
    main()
