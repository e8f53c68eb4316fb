"""Tracked trials recorded once and replayed through the target tracker: tracker changes screened in seconds.

``record``: runs trials as `pushgrasp eval --target-by point` runs them (pg_learning.evaluation.runner.run_trial,
the shipped `lite` policy unless --policy) and keeps, per trial, every observation the target was tracked in
(colour, height, valid, the simulator's ground-truth target mask) and every action's place, yaw and whether it was
executed, one compressed ``<scene>_<seed>.npz`` each (about 20 kB), plus the trial records in ``trials.jsonl`` (the
journal format: `pushgrasp compare` and `pushgrasp kinds` read the folder).

``replay``: feeds the recorded observations and actions, in order, to a fresh TrialTarget (the tracker of the code
that runs the replay) and scores every mask against the ground truth: the share of steps whose mask reaches IoU 0.7
(steps where the target shows MIN_VISIBLE_CELLS or more, as the evaluation counts them) and, at the recorded
grasps, the share whose mask reaches IoU 0.5. The actions are the recorded ones, so a replay measures the tracker on
the trajectories of the code that recorded them; a closed-loop evaluation decides. Two replays of the same folder
list the steps whose masks differ (`--against`). `--target-by mask` names the target by the simulator's first-view
mask instead of the recorded click; `--known-shift` tells the tracker where each push really carried the target.
`--segment-bound` also scores, per step, the one segment of the view (pg_policy.perception.segmentation.
segment_objects) that matches the ground truth best (`segment_bound`): a tracker that only ever picks whole segments
reaches IoU 0.7 on no more steps than those, and where none does, only a cut of a segment (or memory of earlier
views) can; the report splits the steps four ways (the tracker right or not, a whole segment enough or not).

    python -m pg_learning.evaluation.track_replay record --scenes packed/case05 --seed 5000 --trials 10 \
        --allow-train-seeds --out OUT/seq
    python -m pg_learning.evaluation.track_replay replay OUT/seq --save OUT/seq.replay.json
    python -m pg_learning.evaluation.track_replay replay OUT/seq --against OUT/seq.replay.json
    python -m pg_learning.evaluation.track_replay replay OUT/seq --target-by mask --known-shift
    python -m pg_learning.evaluation.track_replay replay OUT/seq --segment-bound

Frames and units: the heightmap grid of pg_core.heightmap; action places in metres in `world`, yaw in radians.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import sys
from pathlib import Path
from typing import Any

import numpy as np

from pg_core.heightmap import Heightmap
from pg_learning.evaluation.target_by import MASK, POINT, TrialTarget
from pg_policy.target_loop.metrics import MIN_VISIBLE_CELLS

FOUND_IOU, GRASP_IOU = 0.7, 0.5


class _Views:
    """Wraps one environment instance's reset / observe (as track_figure's Watcher does) to keep every observation:
    (heightmap, the simulator's ground-truth target mask)."""

    def __init__(self, env: Any) -> None:
        self.seen: list[tuple[Heightmap, np.ndarray]] = []
        self._reset, self._observe = env.reset, env.observe
        self._resetting = False
        env.reset, env.observe = self.reset, self.observe

    def _keep(self, obs: Any) -> Any:
        self.seen.append((obs.heightmap, np.asarray(obs.truth_target, bool).copy()))
        return obs

    def reset(self, *args: Any, **kwargs: Any) -> Any:
        self._resetting = True  # the environment observes within reset: that view is the one reset returns
        try:
            obs = self._reset(*args, **kwargs)
        finally:
            self._resetting = False
        return self._keep(obs)

    def observe(self) -> Any:
        obs = self._observe()
        return obs if self._resetting else self._keep(obs)


def record(scenes: list[str], seed: int, trials: int, out: Path, policy: str = "lite", colours: str = "repeated",
           allow_train_seeds: bool = False) -> int:
    """Record `trials` trials of each scene (seeds seed .. seed + trials - 1) into `out`; trials already there are
    kept (resumable); a trial that took no action (its target not in view to point at) is not. `scenes` as
    `pushgrasp eval --scenes` takes them ("packed" and "household" are their shipped scenes). Returns the number
    recorded. ValueError, before anything is written, for an evaluation seed check that fails or an unknown scene."""
    from pg_learning.environment.sim_env import SimEnv
    from pg_learning.evaluation.runner import (
        DEFAULT_JITTER_XY,
        DEFAULT_JITTER_YAW,
        expand_scenes,
        run_trial,
        trial_scene,
    )
    from pg_policy.policies.registry import make_policy
    from pg_policy.target_loop.episode import Limits, check_eval_seed

    if not allow_train_seeds:
        check_eval_seed(seed)
    scenes = expand_scenes(scenes)
    out.mkdir(parents=True, exist_ok=True)
    journal = out / "trials.jsonl"
    if not journal.exists():
        journal.write_text(json.dumps({"run": {"recorder": "track_replay", "policy": policy, "colours": colours,
                                                "target_by": POINT}}) + "\n")
    done = 0
    with SimEnv(colours=colours) as env, journal.open("a") as log:
        views = _Views(env)
        pol = make_policy(policy)
        for scene in scenes:
            for s in range(seed, seed + trials):
                path = out / f"{scene.replace('/', '_')}_{s}.npz"
                if path.exists():
                    continue
                views.seen = []
                result = run_trial(env, pol, trial_scene(scene, s, DEFAULT_JITTER_XY, DEFAULT_JITTER_YAW), s,
                                   Limits(), scene_name=scene, target_by=POINT)
                trial = result.to_dict()
                log.write(json.dumps({"trial": trial}, default=str) + "\n")
                log.flush()
                if views.seen and trial["actions"]:
                    _save(path, views.seen, trial)
                    done += 1
                    print(f"{scene} seed {s}: {result.termination}, {len(views.seen)} views", flush=True)
                else:  # no action: nothing was tracked (e.g. the target not in view to point at)
                    print(f"{scene} seed {s}: {result.termination}, not recorded: {trial.get('error') or 'no action'}",
                          flush=True)
    return done


def _save(path: Path, seen: list[tuple[Heightmap, np.ndarray]], trial: dict[str, Any]) -> None:
    """One trial's file: its observations and, per action of its record, (push?, x, y, yaw, executed?)."""
    hms = [hm for hm, _ in seen]
    actions = [(float(a["decision"]["primitive"] == "push"), float(a["decision"]["x"]), float(a["decision"]["y"]),
                float(a["decision"]["yaw"]), float(not a["outcome"].get("refused", False))) for a in trial["actions"]]
    meta = {"scene": trial["scene"], "seed": trial["seed"], "resolution": hms[0].resolution}
    np.savez_compressed(path, color=np.stack([h.color for h in hms]), height=np.stack([h.height for h in hms]),
                        valid=np.stack([h.valid for h in hms]), truth=np.stack([t for _, t in seen]),
                        bounds=hms[0].bounds, actions=np.array(actions, np.float64).reshape(-1, 5),
                        meta=json.dumps(meta))


class _Decision:
    def __init__(self, primitive: str, x: float, y: float, yaw: float) -> None:
        self.primitive, self.x, self.y, self.yaw = primitive, x, y, yaw


class _Result:
    def __init__(self, refused: bool) -> None:
        self.refused = refused


def true_shift(before: np.ndarray, after: np.ndarray, resolution: float) -> tuple[float, float] | None:
    """(dx, dy) m in `world`: how far the centroid of the ground-truth target mask moved from `before` to `after`
    ((H, W) bool, rows along y, columns along x); None when either shows fewer than MIN_VISIBLE_CELLS cells."""
    if before.sum() < MIN_VISIBLE_CELLS or after.sum() < MIN_VISIBLE_CELLS:
        return None
    (r0, c0), (r1, c1) = (np.argwhere(m).mean(axis=0) for m in (before, after))
    return float((c1 - c0) * resolution), float((r1 - r0) * resolution)


def segment_bound(hm: Heightmap, truth: np.ndarray) -> tuple[float, str]:
    """(IoU, kind): the best IoU any one segment of `hm` (pg_policy.perception.segmentation.segment_objects)
    reaches against the (H, W) bool ground-truth mask `truth`, and what that segment is: "whole" (IoU >= FOUND_IOU),
    "merged" (it holds FOUND_IOU of the target but more besides: the target joined with others in one segment),
    "split" (FOUND_IOU of it is the target's but it holds less of the target: the target in pieces), "mixed"
    (neither), "none" (no segment meets it: IoU 0.0)."""
    from pg_policy.perception.segmentation import segment_objects

    truth = np.asarray(truth, bool)
    labels = segment_objects(hm)
    best, kind = 0.0, "none"
    for label in np.unique(labels[truth]):
        if not label:
            continue
        seg = labels == label
        common = float((seg & truth).sum())
        score = common / float((seg | truth).sum())
        if score > best:
            held, own = common / float(truth.sum()), common / float(seg.sum())
            best = score
            kind = ("whole" if score >= FOUND_IOU else "merged" if held >= FOUND_IOU else
                    "split" if own >= FOUND_IOU else "mixed")
    return best, kind


def replay_trial(path: Path, push_length: float, target_by: str = POINT, known_shift: bool = False,
                 bound: bool = False) -> dict[str, Any]:
    """The tracker's masks over one recorded trial: scene, seed, per step IoU (None: nothing to score), mask digest,
    whether the target showed enough to count, whether the step was a grasp. target_by: how the first view names
    the target (POINT: a click at its centre, MASK: the simulator's mask). known_shift: after each executed push the
    tracker is told where the target went (`true_shift` of the recorded ground truth) instead of the displacement
    the push predicts: what a tracker that watched the push could know at best. bound: each step also holds
    `segment_iou`, the `segment_bound` of its view."""
    z = np.load(path)
    meta = json.loads(str(z["meta"]))
    target = TrialTarget(target_by, push_length)
    steps = []
    shift = None  # the target's true displacement since the last view, when known_shift and a push moved it
    for t in range(z["height"].shape[0]):
        hm = Heightmap(z["color"][t], z["height"][t], z["valid"][t], meta["resolution"], z["bounds"])
        mask = target.observe(hm, z["truth"][t], shift)
        view = target.view
        steps.append({"iou": view["iou"], "digest": hashlib.md5(np.packbits(mask).tobytes()).hexdigest()[:12],
                      "counted": view["truth_cells"] >= MIN_VISIBLE_CELLS and view["iou"] is not None,
                      "grasp": bool(t < len(z["actions"]) and z["actions"][t][0] < 0.5), "why": view["why"]})
        if bound:
            best, kind = segment_bound(hm, z["truth"][t])
            steps[-1] |= {"segment_iou": round(best, 4), "segment": kind}
        if t < len(z["actions"]):
            a = z["actions"][t]
            target.acted(_Decision("push" if a[0] > 0.5 else "grasp", a[1], a[2], a[3]), _Result(a[4] < 0.5))
            pushed = known_shift and a[0] > 0.5 and a[4] > 0.5 and t + 1 < len(z["truth"])
            shift = true_shift(z["truth"][t], z["truth"][t + 1], meta["resolution"]) if pushed else None
    return {"scene": meta["scene"], "seed": meta["seed"], "steps": steps}


def summary(trials: list[dict[str, Any]]) -> dict[str, int]:
    """Steps counted and found (IoU >= FOUND_IOU), grasps counted and on the target (IoU >= GRASP_IOU); where the
    steps hold `segment_iou` (replay_trial's bound), the counted steps split by whether a whole segment reaches
    FOUND_IOU ("segment") or not ("no_segment") and whether the tracker's mask does ("found_..."), and the first
    views alike ("first_...")."""
    counted = [s for t in trials for s in t["steps"] if s["counted"]]
    grasps = [s for s in counted if s["grasp"]]
    out = {"steps": len(counted), "found": sum(s["iou"] >= FOUND_IOU for s in counted),
           "grasps": len(grasps), "grasps_on_target": sum(s["iou"] >= GRASP_IOU for s in grasps)}
    if counted and all("segment_iou" in s for s in counted):
        firsts = [t["steps"][0] for t in trials if t["steps"] and t["steps"][0]["counted"]]
        for prefix, steps in (("", counted), ("first_", firsts)):
            whole = [s for s in steps if s["segment_iou"] >= FOUND_IOU]
            part = [s for s in steps if s["segment_iou"] < FOUND_IOU]
            out |= {f"{prefix}segment": len(whole), f"{prefix}no_segment": len(part),
                    f"{prefix}found_segment": sum(s["iou"] >= FOUND_IOU for s in whole),
                    f"{prefix}found_no_segment": sum(s["iou"] >= FOUND_IOU for s in part)}
        out["first_steps"] = len(firsts)
        for kind in ("merged", "split", "mixed", "none"):
            out[f"no_segment_{kind}"] = sum(s["segment"] == kind for s in counted)
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=(__doc__ or "").splitlines()[0])
    sub = ap.add_subparsers(dest="command", required=True)
    rec = sub.add_parser("record", help="run and record tracked trials")
    rec.add_argument("--scenes", nargs="+", required=True,
                     help="as `pushgrasp eval --scenes`: packed, household, scene names or generated families")
    rec.add_argument("--seed", type=int, default=1_000_000, help="first trial seed of each scene")
    rec.add_argument("--trials", type=int, default=10, help="trials per scene")
    rec.add_argument("--policy", default="lite", help="policy name or model directory")
    rec.add_argument("--colours", default="repeated", help="scene colours: unique, repeated or same")
    rec.add_argument("--allow-train-seeds", action="store_true", help="accept seeds below 1,000,000")
    rec.add_argument("--out", type=Path, required=True, help="folder of the recorded trials")
    rep = sub.add_parser("replay", help="replay recorded trials through this code's tracker")
    rep.add_argument("folder", type=Path, help="a folder written by `record`")
    rep.add_argument("--save", type=Path, help="write the per-step masks' IoUs and digests here (JSON)")
    rep.add_argument("--against", type=Path, help="a saved replay of the same folder: list the steps that differ")
    rep.add_argument("--target-by", choices=(POINT, MASK), default=POINT,
                     help="how the first view names the target: point (a click at its centre, as recorded) or mask "
                          "(the simulator's mask of the target)")
    rep.add_argument("--known-shift", action="store_true",
                     help="tell the tracker where each push really carried the target (the recorded ground truth) "
                          "instead of the displacement the push predicts: at best what watching the push gives")
    rep.add_argument("--segment-bound", action="store_true",
                     help="also score the one segment of each view that matches the ground truth best: how many "
                          "steps whole segments could get right, and how many of those the tracker does")
    args = ap.parse_args(argv)
    if args.command == "record":
        if args.trials < 1:
            ap.error(f"--trials must be >= 1, got {args.trials}")
        record(args.scenes, args.seed, args.trials, args.out, args.policy, args.colours, args.allow_train_seeds)
        return 0
    from pg_core.geometry import load

    files = sorted(args.folder.glob("*.npz"))
    if not files:
        ap.error(f"{args.folder}: no recorded trials (*.npz)")
    push_length = load().primitives.push_length
    trials = [replay_trial(f, push_length, args.target_by, args.known_shift, args.segment_bound) for f in files]
    s = summary(trials)
    print(f"{args.folder}: {len(trials)} trials; IoU >= {FOUND_IOU} on {s['found']} / {s['steps']} steps "
          f"({100 * s['found'] / max(s['steps'], 1):.1f} %); at grasps IoU >= {GRASP_IOU} on "
          f"{s['grasps_on_target']} / {s['grasps']}")
    if "segment" in s:
        for prefix, what in (("", "steps"), ("first_", "first views")):
            n = max(s[f"{prefix}segment"] + s[f"{prefix}no_segment"], 1)
            print(f"  {what}: a whole segment reaches IoU >= {FOUND_IOU} on {s[f'{prefix}segment']} "
                  f"({100 * s[f'{prefix}segment'] / n:.1f} %), the tracker on {s[f'{prefix}found_segment']} of "
                  f"those; on {s[f'{prefix}no_segment']} none does, the tracker on "
                  f"{s[f'{prefix}found_no_segment']} of those")
        print(f"  where none does, the best segment holds the target with others (merged) on {s['no_segment_merged']}"
              f", a piece of it (split) on {s['no_segment_split']}, neither on {s['no_segment_mixed']}, nothing on "
              f"{s['no_segment_none']}")
    if args.save:
        args.save.write_text(json.dumps(trials))
    if args.against:
        before = {(t["scene"], t["seed"]): t for t in json.loads(args.against.read_text())}
        for t in trials:
            b = before.get((t["scene"], t["seed"]))
            if b and [s["digest"] for s in b["steps"]] != [s["digest"] for s in t["steps"]]:
                print(f"  {t['scene']} seed {t['seed']}: IoU {[s['iou'] for s in t['steps']]} against "
                      f"{[s['iou'] for s in b['steps']]}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
