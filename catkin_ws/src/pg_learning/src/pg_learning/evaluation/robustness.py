"""The camera robustness table: a policy's C and GS under each camera condition, paired with the perfect camera on
the same trials (pg_learning.evaluation.paired).

A condition is a `pushgrasp eval` camera setting (CONDITIONS, a registry): a sensor profile
(pg_sim.world.sensor_model: noise, holes, colour, pose error) and whether the camera is calibrated in simulation
before every trial (`--calibrate`). Runs live in OUT/<policy>/<condition>/ (`pushgrasp eval` output folders, so a
stopped run resumes); the table pools each scene family: a fixed scene's name up to its first "/" (packed/case01 ->
packed), a generated family as named (random-15).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from pg_learning.evaluation.paired import paired
from pg_learning.evaluation.saved_runs import is_run_folder, load_trials
from pg_policy.target_loop.metrics import mean_se
from pg_policy.target_loop.records import TrialRecord


@dataclass(frozen=True)
class Condition:
    """sensor: a profile name or YAML path; calibrate: calibrate the camera before every trial."""

    sensor: str
    calibrate: bool = False
    what: str = ""

    def eval_args(self) -> list[str]:
        """The `pushgrasp eval` arguments of this condition."""
        return ["--sensor", self.sensor] + (["--calibrate"] if self.calibrate else [])


PERFECT = "perfect"
CONDITIONS: dict[str, Condition] = {
    PERFECT: Condition("perfect", what="exact depth, the configured pose"),
    "d435": Condition("d435", what="D435 noise, holes, colour changes, 3 mm / 0.3 deg pose error"),
    "d415": Condition("d415", what="D415 noise, holes, colour changes, pose error"),
    "pose-5mm-1deg": Condition("pose-5mm-1deg", what="camera pose 5 mm / 1 deg off, no calibration"),
    "pose-2cm-2deg": Condition("pose-2cm-2deg", what="camera pose 2 cm / 2 deg off, no calibration"),
    "calibrated-2cm-2deg": Condition("pose-2cm-2deg", True, "2 cm / 2 deg off, then hand-eye calibrated"),
}


def check_conditions(names: Sequence[str]) -> list[str]:
    """The names in order, PERFECT first (added when missing: the pairing needs it); ValueError for an unknown one."""
    unknown = [n for n in names if n not in CONDITIONS]
    if unknown:
        raise ValueError(f"unknown condition(s) {', '.join(unknown)}; known: {', '.join(CONDITIONS)}")
    return [PERFECT] + [n for n in dict.fromkeys(names) if n != PERFECT]


def family(scene: str) -> str:
    """The family a scene is pooled in (module docstring)."""
    return scene.split("/", 1)[0]


def _cell(trials: Sequence[TrialRecord]) -> str:
    c = mean_se(float(t.completed) for t in trials)
    gs = mean_se(t.grasp_success for t in trials if t.grasp_success is not None)
    if c.mean is None:
        return "-"
    return f"{100 * c.mean:.1f} / {'-' if gs.mean is None else f'{100 * gs.mean:.1f}'}"


def table(out: Path, policies: Sequence[str], conditions: Sequence[str]) -> str:
    """Markdown: a row per family and condition, per policy C / GS (%) (trials) and, against the perfect camera on
    the same trials, the completions the perfect camera alone / the condition alone has and the sign-test p.
    Conditions without a run folder are left out."""
    head = "| family | condition | " + " | ".join(f"{p}: C / GS (trials) | {p}: perfect only / condition only (p)"
                                                 for p in policies) + " |"
    lines = [head, "|" + "---|" * (2 + 2 * len(policies))]
    runs: dict[tuple[str, str], list[TrialRecord]] = {}
    for p in policies:
        for c in conditions:
            folder = Path(out) / p / c
            if is_run_folder(folder):
                runs[(p, c)] = load_trials(folder)
    families = sorted({family(t.scene) for ts in runs.values() for t in ts})
    for fam in families:
        for c in conditions:
            cells, seen = [], False
            for p in policies:
                mine = [t for t in runs.get((p, c), []) if family(t.scene) == fam]
                base = [t for t in runs.get((p, PERFECT), []) if family(t.scene) == fam]
                seen = seen or bool(mine)
                if not mine:
                    cells += ["-", "-"]
                    continue
                cells.append(f"{_cell(mine)} ({len(mine)})")
                if c == PERFECT or not base:
                    cells.append("")
                else:
                    r = paired(base, mine)
                    cells.append(f"{r.a_only} / {r.b_only} (p {r.p_c:.2g})")
            if seen:
                lines.append(f"| {fam} | {c} | " + " | ".join(cells) + " |")
    legend = "; ".join(f"`{n}`: {CONDITIONS[n].what}" for n in conditions)
    return "\n".join(lines) + f"\n\nConditions: {legend}.\n"
