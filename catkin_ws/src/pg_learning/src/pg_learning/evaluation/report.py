"""What `pushgrasp eval` writes: results.json (config, every trial, per-scene metrics), results.md (a table laid out
as the paper's Tables I-III: one row per scene, columns C, GS, MN as mean +- standard error) and results.png (bars of
C and GS per scene with standard-error whiskers). C and GS are shown in percent, MN in pushes.

Trials that ended in an error (termination "error", pg_learning.evaluation.errors) count as not completed. results.md
then lists the error reasons under the table (one line per distinct reason with its count and first trials) and the
secondary table has an "errors" column; results.json has, per scene of "summary", "counts" (trials, completed,
errors, lost) beside the metrics ("errors" there: the fraction of trials that ended in an error), and a top-level
"errors" list (reason, count, [scene, seed] of each trial); each error trial carries "error", "error_at" and
"error_trace". Trials whose target left the workspace (termination "target_lost") count as not completed too: the
secondary table has a "lost" column and shows them among the terminations, results.md lists their reasons (each
trial's "message"), and "lost" in a scene's metrics is the fraction of such trials. Trials whose search for a hidden
target found nothing (termination "target_not_found") are counted and listed the same way ("not found").
Trials of the catalogue families (novel-N, ...) also get rows per kind of target (pg_learning.evaluation.kinds):
a table at the end of results.md and "by_target_kind" in results.json.
Runs whose targets are named by a point or a mask (config "target_by", pg_learning.evaluation.target_by) add two
columns to the table, "IoU ≥ 0.7 (% steps)" (of the steps whose target the ground truth shows) and "wrong object
(% grasps)" (grasps that held another object than the target), and "tracking" per scene in results.json
(pg_policy.target_loop.metrics.tracking). Runs by colour write neither.
"""

from __future__ import annotations

import json
import subprocess
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from pg_learning.evaluation.errors import ERROR, errors_json, reason_lines
from pg_learning.evaluation.kinds import by_kind, kind_lines
from pg_policy.target_loop.episode import FAILED_GRASPS, MAX_ACTIONS, TARGET_LOST, TARGET_NOT_FOUND
from pg_policy.target_loop.metrics import IOU_OK, Stat, Tracking, fmt, summarize, tracking_by_scene
from pg_policy.target_loop.records import TrialRecord, plain

METRIC_DOC = (
    "C: completed trials / trials. GS: target grasps / grasp attempts per trial, averaged over the trials with at "
    "least one grasp attempt. MN: pushes per completed trial. Each mean ± standard error over trials "
    "(sample standard deviation / sqrt(n); n/a for fewer than 2 values). See pg_policy.target_loop.metrics."
)


def git_commit(start: Path | None = None) -> str | None:
    """HEAD commit of the repository holding this file (with "-dirty" if the tree has changes), None if unknown."""
    cwd = start or Path(__file__).resolve().parent
    try:
        head = subprocess.run(["git", "rev-parse", "HEAD"], cwd=cwd, capture_output=True, text=True, timeout=5)
        if head.returncode != 0:
            return None
        dirty = subprocess.run(["git", "status", "--porcelain", "--untracked-files=no"], cwd=cwd,
                               capture_output=True, text=True, timeout=5)
        return head.stdout.strip() + ("-dirty" if dirty.stdout.strip() else "")
    except (OSError, subprocess.SubprocessError):
        return None


def markdown(summary: dict[str, dict[str, Stat]], config: dict[str, Any], trials: Sequence[TrialRecord]) -> str:
    """The results.md text: title, the C / GS / MN table, the definitions, and a table of secondary figures."""
    seed, trials_n = int(config.get("seed", 0)), int(config.get("trials", 1))
    tracked = tracking_by_scene(trials) if is_tracked(config) else None
    lines = [
        f"# Evaluation: policy `{config.get('policy')}`",
        "",
        f"{trials_n} trials per scene, seeds {seed}..{seed + trials_n - 1} (trial i: seed + i), "
        f"at most {config.get('max_actions')} actions and {config.get('max_failed_grasps')} failed grasps per trial.",
        "",
        "| Scene | C (%) | GS (%) | MN |",
        "|---|---|---|---|",
    ]
    if tracked is not None:
        lines[4:4] = [f"Target named by {config.get('target_by')} in the first view, then tracked; scene colours "
                      f"{config.get('colours')}. A trial completes only when the grasped object is the target.", ""]
        lines[-2:] = [f"| Scene | C (%) | GS (%) | MN | IoU ≥ {IOU_OK} (% steps) | wrong object (% grasps) |",
                      "|---|---|---|---|---|---|"]
    for name, m in summary.items():
        label = f"**{name}**" if name == "all" else name
        row = f"| {label} | {fmt(m['C'], 100)} | {fmt(m['GS'], 100)} | {fmt(m['MN'], 1, 2)} |"
        lines.append(row if tracked is None else f"{row} {tracking_cells(tracked[name])} |")
    errors = reason_lines(trials)
    if errors:  # before the definitions, so that `pushgrasp eval` prints them with the table
        n_err = sum(t.termination == ERROR for t in trials)
        lines += ["", f"**{n_err} of {len(trials)} trials ended in an error** (counted as not completed; reasons, "
                  "most frequent first):", ""] + errors
    lost = lost_lines(trials)
    if lost:
        lines += ["", f"**{sum(t.termination == TARGET_LOST for t in trials)} of {len(trials)} trials lost the "
                  "target** (it left the workspace; counted as not completed):", ""] + lost
    not_found = lost_lines(trials, termination=TARGET_NOT_FOUND)
    if not_found:
        lines += ["", f"**{sum(t.termination == TARGET_NOT_FOUND for t in trials)} of {len(trials)} trials did not "
                  "find the target** (the search found nothing; counted as not completed):", ""] + not_found
    lines += ["", METRIC_DOC, "", "Secondary figures:", "",
              "| Scene | trials | completed | errors | lost | GS per completion (%) | actions per completed trial "
              "| refused per trial | ended by failed grasps / action budget / target lost / not found |",
              "|---|---|---|---|---|---|---|---|---|"]
    for name, m in summary.items():
        ts = [t for t in trials if name == "all" or t.scene == name]
        c = counts(ts)
        fg = sum(t.termination == FAILED_GRASPS for t in ts)
        ma = sum(t.termination == MAX_ACTIONS for t in ts)
        lines.append(f"| {name} | {c['trials']} | {c['completed']} | {c['errors']} | {c['lost']} | "
                     f"{fmt(m['gs_completed'], 100)} | {fmt(m['actions_completed'], 1, 2)} | "
                     f"{fmt(m['refused'], 1, 2)} | {fg} / {ma} / {c['lost']} / {c['not_found']} |")
    lines += ["", "GS per completion and actions per completed trial are how Xu et al.'s evaluate.py counts "
              "\"grasp success\" and \"motion number\".", ""]
    return "\n".join(lines + kind_lines(trials))


def is_tracked(config: dict[str, Any]) -> bool:
    """Whether the run named its targets by a point or a mask (a tracker followed them)."""
    return config.get("target_by", "colour") != "colour"


def tracking_cells(t: Tracking) -> str:
    """The two tracking cells of a table row: "pct (k/n steps) | pct (k/n grasps)", n/a without steps or grasps."""
    iou = "n/a" if t.iou_ok_fraction is None else f"{100 * t.iou_ok_fraction:.0f} ({t.iou_ok}/{t.steps})"
    wrong = "n/a" if t.wrong_fraction is None else f"{100 * t.wrong_fraction:.0f} ({t.wrong_grasps}/{t.grasps})"
    return f"{iou} | {wrong}"


def tracking_json(t: Tracking) -> dict[str, Any]:
    """results.json's tracking entry of a scene: the pooled counts and the two fractions."""
    return {"steps_visible": t.steps, "steps_iou_ok": t.iou_ok, "iou_ok_fraction": t.iou_ok_fraction,
            "iou_ok_threshold": IOU_OK, "steps_tracked": t.tracked, "steps_unsure": t.unsure, "grasps": t.grasps,
            "wrong_grasps": t.wrong_grasps, "wrong_fraction": t.wrong_fraction}


def counts(trials: Sequence[TrialRecord]) -> dict[str, int]:
    """Trials, completed trials, trials that ended in an error, trials whose target left the workspace and trials
    whose search for the target found nothing."""
    return {"trials": len(trials), "completed": sum(bool(t.completed) for t in trials),
            "errors": sum(t.termination == ERROR for t in trials),
            "lost": sum(t.termination == TARGET_LOST for t in trials),
            "not_found": sum(t.termination == TARGET_NOT_FOUND for t in trials)}


def lost_lines(trials: Sequence[TrialRecord], show: int = 3, termination: str = TARGET_LOST) -> list[str]:
    """One markdown list line per scene with trials of `termination` (target_lost by default): count, the first
    `show` trials (seed, and why when the record says)."""
    by_scene: dict[str, list[TrialRecord]] = {}
    for t in trials:
        if t.termination == termination:
            by_scene.setdefault(t.scene, []).append(t)
    return [f"- {scene}: {len(ts)} × ("
            + "; ".join(f"seed {t.seed}" + (f": {t.message}" if t.message else "") for t in ts[:show])
            + ("; ..." if len(ts) > show else "") + ")" for scene, ts in by_scene.items()]


def plot(summary: dict[str, dict[str, Stat]], path: Path, title: str) -> Path:
    """Grouped bars of C and GS (percent) per scene with standard-error whiskers, written to `path`."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    names = list(summary)
    x = np.arange(len(names))
    fig, ax = plt.subplots(figsize=(max(6.0, 1.0 + 0.9 * len(names)), 4.5), dpi=100)
    for i, (key, colour) in enumerate((("C", "tab:blue"), ("GS", "tab:orange"))):
        means = [100 * (summary[n][key].mean or 0.0) for n in names]
        errs = [100 * (summary[n][key].se or 0.0) for n in names]
        ax.bar(x + (i - 0.5) * 0.38, means, 0.38, yerr=errs, capsize=3, label=key, color=colour)
    ax.set_xticks(x)
    ax.set_xticklabels(names, rotation=30, ha="right")
    ax.set_ylim(0, 105)
    ax.set_ylabel("%")
    ax.set_title(title)
    ax.legend()
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path)
    plt.close(fig)
    return path


def write_results(out: Path, trials: Sequence[TrialRecord], config: dict[str, Any]) -> dict[str, Path]:
    """Write results.json, results.md and results.png into `out` (created); returns their paths by kind."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    summary = summarize(trials)
    paths = {"json": out / "results.json", "md": out / "results.md", "png": out / "results.png"}
    doc = {
        "config": plain(config),
        "metrics_definition": METRIC_DOC,
        "summary": {name: {**{k: plain(s) for k, s in m.items()},
                           "counts": counts([t for t in trials if name == "all" or t.scene == name])}
                    for name, m in summary.items()},
        "errors": errors_json(trials),
        "by_target_kind": [{"scene": scene, "kind": kind, **{k: plain(s) for k, s in m.items()}}
                           for (scene, kind), m in by_kind(trials).items()],
    }
    if is_tracked(config):
        doc["tracking"] = {name: tracking_json(t) for name, t in tracking_by_scene(trials).items()}
    doc["trials"] = [plain(t.to_dict()) for t in trials]
    paths["json"].write_text(json.dumps(doc, indent=1, allow_nan=False) + "\n", encoding="utf-8")
    paths["md"].write_text(markdown(summary, config, trials), encoding="utf-8")
    plot(summary, paths["png"], f"{config.get('policy')}: completion and grasp success (mean ± SE)")
    return paths
