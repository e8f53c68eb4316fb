"""Training arguments: one dataclass, one field per knob, each with its help text (shown by `pushgrasp train -h`)."""

from __future__ import annotations

import argparse
from dataclasses import MISSING, dataclass, field, fields
from pathlib import Path

from pg_core.seeds import MIN_EVAL_SEED  # training seeds are below it, evaluation seeds from it on (disjoint)
from pg_policy.models.device import check_device
from pg_policy.target_loop.episode import DEFAULT_MAX_ACTIONS, DEFAULT_MAX_FAILED_GRASPS, check_train_seed
from pg_sim.world.scene_families import FAMILIES, GENERATED  # the simulator's generated scene families
from pg_sim.world.sensor_model import load_profile
from pg_sim.world.sim_mode import get_sim_mode


def _f(default, help_text: str, **kw):
    return field(default=default, metadata={"help": help_text, **kw})


@dataclass
class TrainConfig:
    stage: str = _f("grasp-agnostic", "training stage: grasp-agnostic | grasp-goal | push | alternate",
                    choices=("grasp-agnostic", "grasp-goal", "push", "alternate"))
    out: Path = _f(Path("runs/lite"), "run directory: checkpoints, replay, log.csv, curves.png per stage")
    backbone: str = _f("lite", "network backbone: lite (CPU-trainable) | lite-os8 (lite at output stride 8; takes "
                                "lite weights) | densenet121 (the paper's)")
    goal: str = _f("none", "goal input: none (mask applied to Q maps only, the paper's main model) | mask")
    pretrained: Path | None = _f(None, "torchvision densenet121 state_dict file (densenet121 backbone only)")
    init: Path | None = _f(None, "checkpoint (last.pt) or exported model directory (grasp.pt [+ push.pt]) to start "
                                 "from (default: the previous stage's last.pt in --out)")
    iterations: int = _f(2000, "actions to execute in this stage (the run resumes from its checkpoint)")
    minutes: float = _f(0.0, "wall-clock budget in minutes for this invocation (0 = no limit)")
    scene: str = _f("random-10", "training scenes: random-N (N blocks dropped), dense-N (N packed blocks), "
                                 "train-novel-N, train-novel-packed-N or train-mixed-N (training objects of the "
                                 "catalogue); a comma-separated list (e.g. dense-8,train-mixed-10) takes them in "
                                 "turn, one per episode")
    seed: int = _f(0, f"training seed (< {MIN_EVAL_SEED}; evaluation uses seeds >= {MIN_EVAL_SEED})")
    lr: float = _f(1e-4, "Adam learning rate (paper: 1e-4)")
    weight_decay: float = _f(2e-5, "Adam weight decay (paper: 2e-5)")
    gamma: float = _f(0.5, "discount factor (paper: 0.5)")
    epsilon_start: float = _f(0.5, "initial exploration probability (epsilon-greedy)")
    epsilon_end: float = _f(0.1, "final exploration probability")
    epsilon_decay: int = _f(1000, "iterations over which epsilon decays linearly")
    replay_capacity: int = _f(2000, "replay buffer capacity (transitions, disk-backed)")
    replay_samples: int = _f(3, "prioritised replay samples learned with each new transition (one batch)")
    grasp_threshold: float = _f(0.5, "grasp when the masked max Q_g exceeds this (push stage: grasp early)")
    max_pushes: int = _f(5, "push stage: pushes before a grasp is forced")
    early_grasp_threshold: float = _f(0.5, "push stage: grasp before max_pushes once the masked max Q_g exceeds "
                                           "this (raise it when the grasp net is over-confident: pushes are rare)")
    push_budget: int = _f(0, "alternate stage: grasp after this many pushes in a row whatever Q_g says, as the "
                             "learned policy does at test time with the same budget (0 = the paper's threshold "
                             "rule alone)")
    guided_exploration: float = _f(0.0, "goal-conditioned stages: fraction of the exploratory (epsilon) actions "
                                        "taken from the heuristic baseline's push rule / free-grasp rule instead of "
                                        "uniformly at random (uniform when the rule has none); rewards stay the "
                                        "simulator's (0 = the paper's uniform exploration)")
    max_actions: int = _f(DEFAULT_MAX_ACTIONS, "actions per episode before the scene is reset")
    max_failed_grasps: int = _f(DEFAULT_MAX_FAILED_GRASPS, "failed grasps per episode before the scene is reset")
    checkpoint_every: int = _f(50, "iterations between checkpoints")
    threads: int = _f(2, "torch CPU threads")
    device: str = _f("cpu", "torch device of the nets: cpu | cuda | cuda:N (the simulator always runs on the CPU)")
    rotations: int = _f(16, "rotations of the heightmap (paper: 16)")
    collectors: int = _f(0, "Ray collector actors that play episodes in parallel and stream transitions to this "
                            "learner (0 = act and learn in this process, the paper's loop)")
    ray_address: str | None = _f(None, "Ray cluster to run the collectors on: auto or HOST:PORT of the head (None: "
                                       "a local Ray of collectors + 1 CPUs)")
    sim_mode: str = _f("fast", "simulation mode: fast (kinematic free-space transit, the table a static body) | "
                               "faithful (every motion stepped); pg_sim.world.sim_mode")
    sensor: str = _f("perfect", "sensor profile of the simulated camera: perfect (exact depth) | d435 | d415 | a "
                                "YAML file of pg_sim.world.sensor_model.SensorProfile keys")
    weights_every: int = _f(10, "learner updates between weight broadcasts to the collectors: the collectors act "
                                "with weights up to this many updates old")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """One --flag per TrainConfig field, with its help text and default."""
    for f in fields(TrainConfig):
        default = f.default if f.default is not MISSING else None
        kind = f.type if isinstance(f.type, type) else str
        name = "--" + f.name.replace("_", "-")
        extra = {"choices": f.metadata["choices"]} if "choices" in f.metadata else {}
        conv = {"Path": Path, "Path | None": Path, "int": int, "float": float, "str": str,
                "str | None": str}.get(str(f.type), kind)
        parser.add_argument(name, type=conv, default=default, help=f"{f.metadata['help']} (default: {default})",
                            **extra)


def from_args(args: argparse.Namespace) -> TrainConfig:
    cfg = TrainConfig(**{f.name: getattr(args, f.name) for f in fields(TrainConfig)})
    check_train_seed(cfg.seed)
    scene_list(cfg.scene)

    if cfg.collectors < 0:
        raise ValueError(f"--collectors {cfg.collectors}: must be >= 0 (0 = act and learn in this process)")
    if cfg.weights_every < 1:
        raise ValueError(f"--weights-every {cfg.weights_every}: must be >= 1 (learner updates between broadcasts)")
    if cfg.ray_address is not None and cfg.collectors == 0:
        raise ValueError(f"--ray-address {cfg.ray_address!r} needs --collectors N >= 1 (the serial loop runs no Ray)")
    check_device(cfg.device)
    get_sim_mode(cfg.sim_mode)  # ValueError naming the modes
    load_profile(cfg.sensor)  # ValueError naming the profiles
    return cfg


def scene_list(spec: str) -> list[str]:
    """The training scene families of `spec` ("dense-8" or "dense-8,train-mixed-10"), in episode order.
    Raises ValueError on an empty list, an entry that is not a generated family with N >= 1, or a family of held-out
    objects (novel-N, novel-packed-N, mixed-N: they are for evaluation only)."""
    scenes = [s.strip() for s in spec.split(",")]
    bad = [s for s in scenes if not (m := GENERATED.match(s)) or int(m.group(2)) < 1]
    if bad:
        raise ValueError(f"--scene {spec!r}: {', '.join(repr(b) for b in bad)} is not a generated family with N >= 1 "
                         f"({', '.join(f'{f}-N' for f, fam in FAMILIES.items() if fam.split != 'heldout')}); "
                         "separate several with commas")
    held = [s for s in scenes if FAMILIES[GENERATED.match(s).group(1)].split == "heldout"]  # type: ignore[union-attr]
    if held:
        raise ValueError(f"--scene {spec!r}: {', '.join(map(repr, held))} draws held-out objects, which are never "
                         "trained on; use the train-... families (train-novel-N, train-novel-packed-N, train-mixed-N)")
    return scenes
