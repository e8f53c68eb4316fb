"""The suite's options: one dataclass, each field with its help text and its value in the short form (`--quick`,
what `make test` runs); the command line is generated from it. An option given explicitly beats the preset."""

from __future__ import annotations

import argparse
from dataclasses import MISSING, dataclass, field, fields
from pathlib import Path
from typing import Any

from .corrupt_models import CASES as MODEL_CASES
from .malformed_scenes import CASES as SCENE_CASES

PROBES = ("ports", "soak", "concurrency", "bad_input", "target_lost", "fuzz", "sensors", "models", "scenes",
          "calibration")
SENSOR_FAULTS = ("projector-frozen", "projector-dead", "sim-frozen", "controller-frozen")
BAD_INPUT_SETS = ("all", "quick")


def opt(default: Any, text: str, quick: Any = None) -> Any:
    """A field with its help text and its value in the short form (None: as in the long form)."""
    return field(default=default, metadata={"help": text, "quick": quick})


@dataclass
class Options:
    out: Path = opt(Path("runs/reliability"), "folder for report.md and report.json (created)")
    seed: int = opt(1, "seed of every random choice (scenes, fuzz requests, corrupt bytes)")
    probes: str = opt("all", f"comma-separated probes to run, in this order: {', '.join(PROBES)} (all: every one)")
    policy: str = opt("lite", "policy of the stack under test (sim.launch policy:=...)", "heuristic")
    scene: str = opt("packed/case01", "scene the stack starts with")
    soak_calls: int = opt(200, "soak: /pg/grasp_target calls, each on a freshly reset scene", 3)
    warmup: int = opt(20, "soak: calls before the warm-up RSS sample; the RSS slope is fitted after it", 1)
    random_share: float = opt(0.5, "soak: share of random scenes (evaluation seeds >= 1000000) among the resets")
    call_timeout: float = opt(300.0, "timeout (s) put in every /pg/grasp_target request of soak and concurrency", 120.0)
    rss_slope_max: float = opt(5.0, "soak: largest RSS growth per node after the warm-up (MB per 100 calls)")
    slope_min_calls: int = opt(10, "soak: calls after the warm-up needed before the RSS slope is judged")
    concurrency_rounds: int = opt(3, "concurrency: rounds of (grasp_target running + second calls)", 1)
    busy_latency_max: float = opt(2.0, "concurrency: largest wall time (s) of a 'busy' refusal")
    refusal_bound: float = opt(5.0, "bad input, fuzz, scenes: wall time (s) within which a refusal must answer")
    answer_wait: float = opt(90.0, "longest wall time (s) to wait for any single answer before calling it a hang")
    max_message: int = opt(1000, "longest acceptable answer message (characters)")
    fuzz: int = opt(500, "fuzz: seeded requests (execute_primitive and reset_scene)", 16)
    fuzz_reset_share: float = opt(0.1, "fuzz: share of reset_scene requests among them", 0.15)
    settle_tolerance: float = opt(0.005, "fuzz: largest object motion (m) in the second after an accepted reset")
    bad_input_cases: str = opt("all", "bad input: 'all' cases or the 'quick' subset", "quick")
    sensor_faults: str = opt("all", f"sensors: faults to inject ({', '.join(SENSOR_FAULTS)}; all: every one)",
                             "projector-frozen,projector-dead,sim-frozen")
    error_bound: float = opt(20.0, "sensors: wall time (s) within which a call must answer with an error")
    recovery_bound: float = opt(90.0, "sensors: longest wall time (s) to wait for a call to succeed again")
    model_cases: str = opt("all", f"models: corrupt model cases ({', '.join(MODEL_CASES)}; all: every one)",
                           "zero-byte,pickle-code,wrong-arch")
    model_exit_bound: float = opt(120.0, "models: wall time (s) within which the policy node must exit")
    scene_cases: str = opt("all", f"scenes: malformed scene cases ({', '.join(list(SCENE_CASES)[1:])}; all: every "
                           "one; the valid control file always runs)",
                           "bad-yaml,missing-pose,nan-pose,huge-size,500-objects,shared-target-colour")
    render_cases: str = opt("all", "scenes: cases also given to `pushgrasp scene render` (all: every one)",
                            "bad-yaml,nan-pose,huge-size")
    render_bound: float = opt(120.0, "scenes, calibration: wall time (s) within which `pushgrasp scene render` and "
                              "`pushgrasp calibrate --sim` must exit")
    probe_budget: float = opt(7200.0, "wall-time budget (s) of one probe: its loops stop when it is spent", 150.0)
    startup_timeout: float = opt(240.0, "wall time (s) for the stack to come up")
    keep_temp: bool = opt(False, "keep the temporary folder (ROS logs, launch logs, generated files)")
    quick: bool = opt(False, "the short form: small counts (the values marked 'quick' in this help)")

    def selected(self, spec: str, known: tuple[str, ...]) -> list[str]:
        """The names of a comma-separated selection ('all': every known one); raises ValueError for unknown ones."""
        if spec.strip() == "all":
            return list(known)
        names = [s.strip() for s in spec.split(",") if s.strip()]
        unknown = [n for n in names if n not in known]
        if unknown:
            raise ValueError(f"unknown {unknown}; known: {', '.join(known)}")
        return names


def parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="scripts/reliability.py",
        description="pushgrasp fault suite: starts sim.launch on a private ROS master and runs the probes (soak, "
                    "concurrency, bad input, target lost, fuzz, sensor faults, corrupt models, malformed scenes, "
                    "calibration without the board, listening ports); writes report.md and report.json to --out. "
                    "Exit status 0 only when every invariant held and nothing the suite started was left running.")
    for f in fields(Options):
        flag = "--" + f.name.replace("_", "-")
        quick = f.metadata.get("quick")
        text = f.metadata["help"] + (f" [quick: {quick}]" if quick is not None else "")
        if f.type in ("bool", bool):
            p.add_argument(flag, action="store_true", default=None, help=text)
        else:
            kind = {"int": int, "float": float, "Path": Path}.get(str(f.type), str)
            p.add_argument(flag, type=kind, default=None, metavar=f.name.upper(), help=f"{text} (default {f.default})")
    return p


def parse(argv: list[str] | None = None) -> Options:
    ns = parser().parse_args(argv)
    quick = bool(ns.quick)
    values: dict[str, Any] = {}
    for f in fields(Options):
        given = getattr(ns, f.name)
        if given is not None:
            values[f.name] = given
        elif quick and f.metadata.get("quick") is not None:
            values[f.name] = f.metadata["quick"]
        elif f.default is not MISSING:
            values[f.name] = f.default
    opts = Options(**values)
    try:
        opts.selected(opts.probes, PROBES)
        opts.selected(opts.sensor_faults, SENSOR_FAULTS)
        opts.selected(opts.model_cases, MODEL_CASES)
        opts.selected(opts.scene_cases, tuple(SCENE_CASES))
        opts.selected(opts.render_cases, tuple(SCENE_CASES))
        if opts.bad_input_cases not in BAD_INPUT_SETS:
            raise ValueError(f"--bad-input-cases {opts.bad_input_cases!r}: give one of {BAD_INPUT_SETS}")
    except ValueError as exc:
        parser().error(str(exc))
    return opts
