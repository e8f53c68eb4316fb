"""Self-supervised training loop of the paper: act in the simulator, label the executed pixel, learn, repeat.

One iteration = observe -> masked Q maps -> epsilon-greedy decision -> execute -> reward (with hindsight
relabelling) -> store in prioritised replay -> Huber loss on the executed pixel (grasps also at rotation r + R/2)
for the new transition batched with `replay_samples` replayed ones -> log. Checkpoints (nets, optimisers, counters, RNG
state; the replay lives on disk) every `checkpoint_every` iterations: rerunning the same command resumes.
"""

from __future__ import annotations

import csv
import json
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import torch

from pg_core.geometry import load
from pg_core.heightmap import Heightmap
from pg_core.target_mask import MIN_VISIBLE_CELLS, target_mask
from pg_policy.environment.sim_env import SimEnv
from pg_policy.models.device import check_device
from pg_policy.models.model_io import ModelLoadError, load_qnet
from pg_policy.models.nets.registry import get_backbone
from pg_policy.perception import scene_change
from pg_policy.policies.heuristic_planner import HeuristicPlanner
from pg_policy.training import qtensor, rewards
from pg_policy.training.checkpoint import load_checkpoint
from pg_policy.training.config import TrainConfig, scene_list
from pg_policy.training.curves import plot_curves
from pg_policy.training.experience_replay import ReplayBuffer, Transition
from pg_policy.training.stages import STAGES, choose_primitive, epsilon, explore_action

# explored: 0 = greedy, 1 = uniformly random, 2 = the heuristic's push or free grasp (guided exploration)
LOG_FIELDS = ["iteration", "episode", "primitive", "rotation", "row", "col", "q", "explored", "reward", "grasped",
              "success", "epsilon", "loss", "sim_s", "wall_s"]


@dataclass(frozen=True)
class Action:
    """One chosen action: primitive, rotation index, heightmap cell; pose (x, y, z, yaw) in `world` m / rad;
    explored: 0 greedy, 1 random, 2 guided; epsilon of the iteration; q: the Q maps it was chosen on (None for a
    random grasp); grasp_max: masked max of Q_g over the goal (nan without maps); goal: (H, W) bool goal mask and its
    colour name (None: goal-agnostic)."""

    primitive: str
    rotation: int
    row: int
    col: int
    pose: tuple[float, float, float, float]
    explored: int
    epsilon: float
    q: dict[str, np.ndarray] | None
    grasp_max: float
    goal: np.ndarray
    goal_color: str | None


class Trainer:
    """Owns the env, the two nets, their optimisers and replay buffers for one stage of one run directory."""

    def __init__(self, cfg: TrainConfig) -> None:
        torch.set_num_threads(cfg.threads)
        torch.manual_seed(cfg.seed)
        self.cfg = cfg
        self.scenes_ = scene_list(cfg.scene)  # training scene families, one per episode in turn
        self.device = check_device(cfg.device)
        self.geo = load()
        self.stage = STAGES[cfg.stage]
        self.dir = Path(cfg.out) / cfg.stage
        self.dir.mkdir(parents=True, exist_ok=True)
        self.nets = {role: qtensor.build(cfg, role).to(self.device) for role in ("grasp", "push")}
        self.opts = {role: torch.optim.Adam(net.parameters(), lr=cfg.lr, weight_decay=cfg.weight_decay)
                     for role, net in self.nets.items()}
        shape = (self.geo.heightmap.rows, self.geo.heightmap.cols)
        self.replay = {role: ReplayBuffer(self.dir / f"replay_{role}", cfg.replay_capacity, shape)
                       for role in self.stage.trains}
        self.iteration, self.episode = 0, 0
        self.rng = np.random.default_rng(cfg.seed)
        self._restore()
        self.env = SimEnv(self.geo)
        self.guide = None
        if cfg.guided_exploration > 0 and not self.stage.goal_agnostic:
            self.guide = HeuristicPlanner(self.geo)
        self.log_ = self.dir / "log.csv"

    # -- checkpoints -------------------------------------------------------------------------------------------
    def _restore(self) -> None:
        last = self.dir / "last.pt"
        if last.exists():
            ck = load_checkpoint(last)
            for role, net in self.nets.items():
                net.load_state_dict(ck["nets"][role])
            for role, opt in self.opts.items():
                if role in ck["opts"]:
                    opt.load_state_dict(ck["opts"][role])
            self.iteration, self.episode = ck["iteration"], ck["episode"]
            self.rng.bit_generator.state = ck["rng"]
            print(f"[train] resuming {self.stage.name} at iteration {self.iteration} from {last}")
            return
        init = self.cfg.init or (Path(self.cfg.out) / self.stage.previous / "last.pt" if self.stage.previous else None)
        if init is not None:
            if not Path(init).exists():
                raise FileNotFoundError(f"stage {self.stage.name} starts from {init}, which does not exist: train "
                                        f"stage '{self.stage.previous}' first or pass --init")
            if Path(init).is_dir():
                self._init_from_models(Path(init))
            else:
                ck = load_checkpoint(init)
                for role, net in self.nets.items():
                    net.load_state_dict(ck["nets"][role])
            print(f"[train] {self.stage.name}: starting from {init}")

    def _init_from_models(self, folder: Path) -> None:
        """Weights from exported TorchScript files (`pushgrasp export` layout); a net without a file keeps its
        fresh initialisation. Raises ModelLoadError for a file made for another backbone or goal input."""

        for role, net in self.nets.items():
            path = folder / f"{role}.pt"
            if not path.is_file():
                print(f"[train] {role} net: no {path}, starting from scratch")
                continue
            scripted, meta = load_qnet(path)
            takes = (self.cfg.backbone, *get_backbone(self.cfg.backbone).weights_of)
            if meta.get("backbone") not in takes or meta.get("goal") != self.cfg.goal:
                raise ModelLoadError(f"{path} is a {meta.get('backbone')!r} / goal {meta.get('goal')!r} model; this "
                                     f"run trains {self.cfg.backbone!r} / goal {self.cfg.goal!r}")
            own = net.state_dict()
            net.load_state_dict({k: v for k, v in scripted.state_dict().items() if k in own})

    def save(self) -> Path:
        for buf in self.replay.values():
            buf.flush()
        ck = {"nets": {r: {k: v.cpu() for k, v in n.state_dict().items()} for r, n in self.nets.items()},
              "opts": {r: o.state_dict() for r, o in self.opts.items()},
              "iteration": self.iteration, "episode": self.episode, "rng": self.rng.bit_generator.state,
              "config": {k: str(v) for k, v in vars(self.cfg).items()}, "stage": self.stage.name}
        tmp = self.dir / "last.pt.tmp"
        torch.save(ck, tmp)
        tmp.replace(self.dir / "last.pt")
        return self.dir / "last.pt"

    # -- learning ----------------------------------------------------------------------------------------------
    def _label(self, t: Transition) -> float:
        if t.primitive == "grasp" or t.done:
            return t.reward
        hm = Heightmap(t.next_color, t.next_height, t.next_height > 0, self.geo.heightmap.resolution,
                       self.geo.workspace.bounds)
        q = qtensor.q_maps(self.nets, hm, t.next_mask, ("grasp", "push"))
        future = max(qtensor.masked_max(q["grasp"], t.next_mask), qtensor.masked_max(q["push"], t.next_mask))
        return t.reward + self.cfg.gamma * future

    def learn(self, batch: list[Transition]) -> tuple[float, list[float]]:
        """One Huber step on the executed pixels of a batch of transitions of one primitive (a grasp also at
        rotation r + R/2: the parallel jaw is symmetric). Returns (mean loss, |TD error| per transition)."""
        role = batch[0].primitive
        net, opt = self.nets[role], self.opts[role]
        labels = [self._label(t) for t in batch]
        half = self.cfg.rotations // 2
        items = [(k, t, r) for k, t in enumerate(batch)
                 for r in ([t.rotation, (t.rotation + half) % self.cfg.rotations] if role == "grasp" else [t.rotation])]
        cols = [qtensor.tensors(t.color, t.height, t.mask, self.device) for _, t, _ in items]
        color, depth, mask = (torch.cat([c[i] for c in cols]) for i in range(3))
        net.train()
        rots = torch.tensor([r for _, _, r in items], dtype=torch.int64, device=self.device)
        q = net.forward_indexed(color, depth, mask, rots)
        pred = torch.stack([q[i, t.row, t.col] for i, (_, t, _) in enumerate(items)])
        target = torch.tensor([labels[k] for k, _, _ in items], dtype=pred.dtype, device=self.device)
        loss = torch.nn.functional.smooth_l1_loss(pred, target, reduction="mean")
        opt.zero_grad()
        loss.backward()
        opt.step()
        first = {}
        values = pred.detach().cpu().tolist()
        for i, (k, _, _) in enumerate(items):
            first.setdefault(k, abs(values[i] - labels[k]))
        return float(loss.detach()), [first[k] for k in range(len(batch))]

    # -- acting ------------------------------------------------------------------------------------------------
    def _goal(self, obs) -> tuple[np.ndarray, str | None]:
        """(goal mask, goal colour). Goal-agnostic: every object cell."""

        if self.stage.goal_agnostic:
            return obs.heightmap.valid & (obs.heightmap.height > 0.01), None
        return target_mask(obs.heightmap.color, obs.heightmap.valid, obs.target), obs.target

    def _pick_target(self) -> None:
        if self.stage.goal_agnostic:
            return
        colors = self.env.object_colors()
        unique = [c for c in colors if colors.count(c) == 1]
        if unique:
            self.env.retarget(unique[int(self.rng.integers(len(unique)))])

    def _reset(self, draws: int = 10) -> object:
        """A new episode: the next training scene; goal-conditioned stages draw again (up to `draws` scenes) while
        the picked target is not visible at all (a policy cannot act on a target it does not see)."""
        for _ in range(draws):
            self.episode += 1
            seed = (self.cfg.seed * 100_003 + self.episode) % 1_000_000
            self.env.reset(self.scenes_[(self.episode - 1) % len(self.scenes_)], seed=seed)
            self._pick_target()
            self.ep_ = {"actions": 0, "failed": 0, "pushes": 0, "in_row": 0}
            obs = self.env.observe()
            if not self._episode_over(obs):
                break
        return obs

    def _episode_over(self, obs=None) -> bool:
        """Budget spent, scene empty, or (goal-conditioned stages) the target gone or not visible in `obs`: an
        action on an empty goal mask has no target to learn about (its push region and change region are empty)."""

        ep, cfg = self.ep_, self.cfg
        if ep["actions"] >= cfg.max_actions or ep["failed"] >= cfg.max_failed_grasps:
            return True
        if len(self.env.world.objects) == 0:
            return True
        if self.stage.goal_agnostic:
            return False
        if not self.env.target_present():
            return True
        return obs is not None and int(self._goal(obs)[0].sum()) < MIN_VISIBLE_CELLS

    def step(self, obs) -> tuple[dict, object]:
        """One iteration of the paper's loop (act, execute, label, learn); returns (log row, next observation)."""
        action = self.act(obs)
        result = self.env.step(action.primitive, *action.pose)
        self.ep_["actions"] += 1
        nxt = self.env.observe()
        transition, success = self.label(obs, action, result, nxt)
        loss = self.learn_from(transition)
        q = action.q[action.primitive][action.rotation, action.row, action.col] if action.q is not None else None
        row_log = {"iteration": self.iteration, "episode": self.episode, "primitive": action.primitive,
                   "rotation": action.rotation, "row": action.row, "col": action.col,
                   "explored": int(action.explored), "q": round(float(q), 4) if q is not None else "",
                   "reward": transition.reward, "grasped": int(result.grasped), "success": int(success),
                   "epsilon": round(action.epsilon, 3), "loss": round(loss, 5), "sim_s": round(result.sim_time, 2)}
        return row_log, nxt

    def act(self, obs) -> Action:
        """Epsilon-greedy (optionally guided) choice of primitive, rotation and cell on the masked Q maps."""
        cfg, hm = self.cfg, obs.heightmap
        goal, goal_color = self._goal(obs)
        eps = epsilon(self.iteration, cfg.epsilon_start, cfg.epsilon_end, cfg.epsilon_decay)
        explored = bool(self.rng.random() < eps)
        if explored and not self.stage.uses_push:  # a random grasp needs no Q maps: skip the forward pass
            q, gmax = None, float("nan")
        else:
            q = qtensor.q_maps(self.nets, hm, goal, ("grasp", "push") if self.stage.uses_push else ("grasp",))
            gmax = qtensor.masked_max(q["grasp"], goal)
        threshold = cfg.early_grasp_threshold if self.stage.name == "push" else cfg.grasp_threshold
        primitive = choose_primitive(self.stage, gmax, self.ep_["pushes"], threshold, cfg.max_pushes,
                                     self.ep_["in_row"], cfg.push_budget)
        self.ep_["in_row"] = self.ep_["in_row"] + 1 if primitive == "push" else 0
        region = goal if primitive == "grasp" else qtensor.push_region(goal, self.geo)
        guided = None
        if explored and self.guide is not None and self.rng.random() < cfg.guided_exploration:
            guided = self.guide.guide(primitive, hm, goal)
        if guided is not None:
            rot, row, col, explored = guided.rotation, guided.row, guided.col, 2
        elif explored:
            rot, row, col = explore_action(self.rng, region, cfg.rotations)
        else:
            rot, row, col = qtensor.masked_argmax(q[primitive], region)
        pose = qtensor.action_pose(hm, primitive, rot, row, col, self.geo)
        return Action(primitive, rot, row, col, pose, int(explored), eps, q, gmax, goal, goal_color)

    def label(self, obs, action: Action, result, nxt) -> tuple[Transition, bool]:
        """The transition and its reward (DESIGN.md section 7; grasps relabelled in hindsight), and whether the
        action succeeded."""

        hm, goal = obs.heightmap, action.goal
        rot, row, col = action.rotation, action.row, action.col
        if action.primitive == "grasp":
            # hindsight relabelling: the goal of this grasp is the object under the executed pixel
            pixel_color = qtensor.color_at(hm, row, col)
            reward = rewards.grasp_reward(result.grasped_color is not None and result.grasped_color == pixel_color)
            success = result.target_grasped if action.goal_color else result.grasped_color is not None
            self.ep_["failed"] += 0 if success else 1
            mask = target_mask(hm.color, hm.valid, pixel_color) if pixel_color else goal
            return Transition(hm.color, hm.height, mask, "grasp", rot, row, col, reward), success
        self.ep_["pushes"] += 1
        nmask = target_mask(nxt.heightmap.color, nxt.heightmap.valid, obs.target)
        q_after = qtensor.q_maps(self.nets, nxt.heightmap, nmask, ("grasp",))
        changed = scene_change.scene_changed(hm, nxt.heightmap, goal, radius_m=scene_change.PUSH_CHANGE_RADIUS_M)
        occ = [rewards.occupancy_ratio(h, m, 0.05, 0.01) for h, m in ((hm, goal), (nxt.heightmap, nmask))]
        reward = rewards.push_reward(action.grasp_max, qtensor.masked_max(q_after["grasp"], nmask), changed, occ[0],
                                     occ[1])
        t = Transition(hm.color, hm.height, goal, "push", rot, row, col, reward, nxt.heightmap.color,
                       nxt.heightmap.height, nmask, done=False)
        return t, reward > 0

    def learn_from(self, t: Transition) -> float:
        """Store the transition in its prioritised replay and take one gradient step on it batched with replayed
        ones (priorities updated from the new TD errors); the loss, 0.0 for a primitive this stage does not train."""
        if t.primitive not in self.replay:
            return 0.0
        buf = self.replay[t.primitive]
        picks = [i for i in (buf.sample(self.rng) for _ in range(self.cfg.replay_samples)) if i is not None]
        loss, tds = self.learn([t] + [buf.get(i) for i in picks])
        buf.add(t, tds[0])
        for i, td in zip(picks, tds[1:], strict=True):
            buf.update_priority(i, td)
        return loss

    def run(self) -> Path:
        from tqdm import tqdm

        cfg = self.cfg
        new_log = not self.log_.exists()
        start, wall0 = self.iteration, time.perf_counter()
        recent: list[int] = []
        with self.log_.open("a", newline="") as f:
            writer = csv.DictWriter(f, fieldnames=LOG_FIELDS)
            if new_log:
                writer.writeheader()
            obs = self._reset()
            bar = tqdm(total=cfg.iterations, initial=self.iteration, desc=f"train {self.stage.name}", unit="it")
            while self.iteration < cfg.iterations:
                if cfg.minutes and time.perf_counter() - wall0 > cfg.minutes * 60:
                    print(f"[train] wall-clock budget of {cfg.minutes} min reached")
                    break
                row, obs = self.step(obs)
                row["wall_s"] = round(time.perf_counter() - wall0, 1)
                writer.writerow(row)
                if row["primitive"] == "grasp":
                    recent = (recent + [row["success"]])[-100:]
                self.iteration += 1
                bar.update(1)
                bar.set_postfix(grasp_success=f"{np.mean(recent):.2f}" if recent else "-", eps=row["epsilon"])
                if self._episode_over(obs):
                    obs = self._reset()
                if self.iteration % cfg.checkpoint_every == 0:
                    f.flush()
                    self.save()
            bar.close()
        path = self.save()

        plot_curves(self.log_, self.dir / "curves.png", title=f"{self.stage.name} ({cfg.backbone}, goal {cfg.goal})")
        (self.dir / "summary.json").write_text(json.dumps(
            {"stage": self.stage.name, "iterations": self.iteration, "this_run": self.iteration - start,
             "recent_grasp_success": float(np.mean(recent)) if recent else None}, indent=2))
        self.env.close()
        return path
