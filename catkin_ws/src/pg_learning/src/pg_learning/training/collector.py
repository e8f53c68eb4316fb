"""The acting half of the paper's training loop: play episodes in the simulator and turn each action into a labelled
transition. Ray-free; the learner (`pg_learning.training.trainer.Trainer`) owns the learning half.

One `Collector.step(iteration)` = (a new episode first when the last one is over, or none was started) -> masked Q
maps -> epsilon-greedy decision (epsilon of the learner's `iteration`) -> execute -> reward (with hindsight
relabelling) -> (Transition, log row). The row holds every log.csv column but `loss`, `wall_s` and `collector`, which
the learner adds. A collector never learns: it acts with the nets it is given (shared with the learner in the serial
loop, or its own copies that `set_weights` refreshes when it runs in a Ray actor).

Episode numbering: collector `index` of `count` numbers its episodes first_episode + index + 1, + count, + 2 count,
...; an episode's scene seed is pg_core.seeds.train_seed(seed, episode), below the evaluation seeds, so the
collectors of one run play disjoint scenes, and one collector (index 0 of 1) numbers them first_episode + 1, + 2, ...
as the serial loop always did. A scene whose target is not visible is skipped (the number is used up).

Episodes follow the one episode protocol (pg_policy.target_loop.episode: limits, counting, termination reasons, the
target memory); a goal-conditioned episode also ends when its target is not visible (termination target_hidden: an
empty goal mask has no push region to learn about), a goal-agnostic one when the scene is empty (scene_empty).
"""

from __future__ import annotations

import dataclasses
import sys
from dataclasses import dataclass
from typing import Any

import numpy as np
import torch

from pg_core.geometry import Geometry, load
from pg_core.seeds import train_seed
from pg_core.target_mask import MIN_VISIBLE_CELLS, target_mask
from pg_learning.environment.sim_env import EnvObservation, SimEnv, StepResult
from pg_learning.training import qtensor, rewards
from pg_learning.training.config import TrainConfig, scene_list
from pg_learning.training.experience_replay import Transition
from pg_learning.training.stages import STAGES, choose_primitive, epsilon, explore_action
from pg_policy.models.nets.qnet import QNet
from pg_policy.perception import scene_change
from pg_policy.policies.heuristic_planner import HeuristicPlanner
from pg_policy.target_loop.episode import SCENE_EMPTY, TARGET_HIDDEN, TARGET_LOST, Episode, Limits, Outcome

ROLES = ("grasp", "push")


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

    @property
    def x(self) -> float:
        return self.pose[0]

    @property
    def y(self) -> float:
        return self.pose[1]


class Collector:
    """A simulator, the stage's acting rules and the nets to act with, for one stream of episodes.

    `nets`: the {role: QNet} to act with (the serial loop passes the learner's own, so acting always sees the latest
    weights); None builds CPU copies of the run's variant whose weights `set_weights` sets. `rng`: the generator of
    every random choice (the serial loop passes the learner's, so one generator is drawn in the paper loop's order:
    act, learn, next episode); None makes one of its own from (cfg.seed, index, first_episode)."""

    def __init__(self, cfg: TrainConfig, index: int = 0, count: int = 1, first_episode: int = 0,
                 nets: dict[str, QNet] | None = None, rng: np.random.Generator | None = None,
                 geo: Geometry | None = None) -> None:
        if not 0 <= index < count:
            raise ValueError(f"collector index {index} is not in [0, {count})")
        self.cfg, self.index, self.count = cfg, index, count
        self.scenes_ = scene_list(cfg.scene)  # training scene families, one per episode in turn
        self.stage = STAGES[cfg.stage]
        self.geo = geo if geo is not None else load()
        if nets is None:  # own copies on the CPU; a --pretrained file is not needed (set_weights overwrites them)
            nets = {role: qtensor.build(dataclasses.replace(cfg, pretrained=None), role) for role in ROLES}
        self.nets = nets
        if rng is None:  # a child of the learner's seed sequence: a stream of its own for every (index, first_episode)
            rng = np.random.default_rng(np.random.SeedSequence(cfg.seed, spawn_key=(index, first_episode)))
        self.rng = rng
        self.episode = first_episode + index + 1 - count  # the last episode this collector started (none yet)
        self.weights_iteration = -1  # learner iteration of the weights last set (-1: the nets as given)
        self.ep_ = Episode(self._limits())  # the running episode (pg_policy.target_loop.episode)
        self.pushes_ = 0  # pushes chosen in the running episode (the push stage's budget)
        self.in_row_ = 0  # pushes chosen in a row (the push budget of the alternate stage)
        self.obs_: EnvObservation | None = None  # the observation to act on; None: start an episode first
        self.env = SimEnv(self.geo, sim_mode=cfg.sim_mode, sensor=cfg.sensor)
        self.guide = None
        if cfg.guided_exploration > 0 and not self.stage.goal_agnostic:
            self.guide = HeuristicPlanner(self.geo)

    def close(self) -> None:
        self.env.close()

    def set_weights(self, state_dicts: dict[str, dict[str, torch.Tensor]], iteration: int) -> None:
        """Load the learner's {role: state_dict} (CPU tensors) of learner `iteration` into the nets to act with."""
        for role, sd in state_dicts.items():
            self.nets[role].load_state_dict(sd)
        self.weights_iteration = iteration

    # -- episodes ----------------------------------------------------------------------------------------------
    def _goal(self, obs: EnvObservation) -> tuple[np.ndarray, str | None]:
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

    def _reset(self, draws: int = 10) -> EnvObservation:
        """A new episode: the next training scene; goal-conditioned stages draw again (up to `draws` scenes) while
        the picked target is not visible at all (a policy cannot act on a target it does not see). A scene that
        cannot be built (ValueError from the simulator: a bad object file, a scene that does not come to rest) is
        reported on stderr and skipped like an invisible target. Raises RuntimeError when no draw gives a scene."""
        obs, errors = None, []
        for _ in range(draws):
            self.episode += self.count
            seed = train_seed(self.cfg.seed, self.episode)
            scene = self.scenes_[(self.episode - 1) % len(self.scenes_)]
            try:
                self.env.reset(scene, seed=seed)
            except ValueError as exc:
                errors.append(f"{scene} seed {seed}: {exc}")
                print(f"[train] episode {self.episode}: scene {scene} seed {seed} skipped: {exc}", file=sys.stderr)
                continue
            self._pick_target()
            self.ep_ = Episode(self._limits(), target=self.env.target, goal_agnostic=self.stage.goal_agnostic)
            self.pushes_ = self.in_row_ = 0
            obs = self.env.observe()
            self._observe(obs)
            if not self._episode_over(obs):
                break
        if obs is None:
            raise RuntimeError(f"no training scene could be built in {draws} draws; last: {errors[-1]}")
        return obs

    def _limits(self) -> Limits:
        return Limits(self.cfg.max_actions, self.cfg.max_failed_grasps)

    def _observe(self, obs: EnvObservation) -> None:
        """Goal-conditioned stages: tell the episode the observation (its target memory; the simulator's ground truth
        decides target_lost)."""
        if not self.stage.goal_agnostic:
            self.ep_.observe(obs.heightmap, self._goal(obs)[0], self.env.target_outside())

    def _episode_over(self, obs: EnvObservation | None = None) -> bool:
        """The episode protocol's verdict (target grasped, target lost, failed grasps, budget), the scene empty, or
        (goal-conditioned stages) the target gone or not visible in `obs`: an action on an empty goal mask has no
        target to learn about (its push region and change region are empty)."""
        ep = self.ep_
        if ep.over():
            return True
        if len(self.env.world.objects) == 0:
            ep.stop(SCENE_EMPTY, "no object left")
            return True
        if self.stage.goal_agnostic:
            return False
        if not self.env.target_present():
            ep.stop(TARGET_LOST, "the target is gone from the scene")
            return True
        if obs is not None and int(self._goal(obs)[0].sum()) < MIN_VISIBLE_CELLS:
            ep.stop(TARGET_HIDDEN, "target not visible")
            return True
        return False

    # -- one action --------------------------------------------------------------------------------------------
    def step(self, iteration: int) -> tuple[Transition, dict[str, Any]]:
        """One action of the paper's loop at learner `iteration` (the epsilon schedule's clock): a new episode first
        when due, then act, execute, label. Returns the transition and its log row (no loss, wall_s, collector)."""
        if self.obs_ is None or self._episode_over(self.obs_):
            self.obs_ = self._reset()
        obs = self.obs_
        action = self.act(obs, iteration)
        result = self.env.step(action.primitive, *action.pose)
        nxt = self.env.observe()
        transition, success = self.label(obs, action, result, nxt)
        self.pushes_ += int(action.primitive == "push")
        self.ep_.record(action, Outcome(refused=result.refused, target_grasped=action.primitive == "grasp" and success,
                                        message=result.message))
        self._observe(nxt)
        self.obs_ = nxt
        q = action.q[action.primitive][action.rotation, action.row, action.col] if action.q is not None else None
        row = {"iteration": iteration, "episode": self.episode, "primitive": action.primitive,
               "rotation": action.rotation, "row": action.row, "col": action.col,
               "explored": int(action.explored), "q": round(float(q), 4) if q is not None else "",
               "reward": transition.reward, "grasped": int(result.grasped), "success": int(success),
               "epsilon": round(action.epsilon, 3), "sim_s": round(result.sim_time, 2)}
        return transition, row

    def act(self, obs: EnvObservation, iteration: int) -> Action:
        """Epsilon-greedy (optionally guided) choice of primitive, rotation and cell on the masked Q maps."""
        cfg, hm = self.cfg, obs.heightmap
        goal, goal_color = self._goal(obs)
        eps = epsilon(iteration, cfg.epsilon_start, cfg.epsilon_end, cfg.epsilon_decay)
        explored = bool(self.rng.random() < eps)
        if explored and not self.stage.uses_push:  # a random grasp needs no Q maps: skip the forward pass
            q, gmax = None, float("nan")
        else:
            q = qtensor.q_maps(self.nets, hm, goal, ROLES if self.stage.uses_push else ("grasp",))
            gmax = qtensor.masked_max(q["grasp"], goal)
        threshold = cfg.early_grasp_threshold if self.stage.name == "push" else cfg.grasp_threshold
        primitive = choose_primitive(self.stage, gmax, self.pushes_, threshold, cfg.max_pushes, self.in_row_,
                                     cfg.push_budget)
        self.in_row_ = self.in_row_ + 1 if primitive == "push" else 0
        region = goal if primitive == "grasp" else qtensor.push_region(goal, self.geo)
        guided = None
        if explored and self.guide is not None and self.rng.random() < cfg.guided_exploration:
            guided = self.guide.guide(primitive, hm, goal)
        if guided is not None:
            rot, row, col, explored = guided.rotation, guided.row, guided.col, 2
        elif explored:
            rot, row, col = explore_action(self.rng, region, cfg.rotations)
        else:
            assert q is not None  # greedy: the maps were computed
            rot, row, col = qtensor.masked_argmax(q[primitive], region)
        pose = qtensor.action_pose(hm, primitive, rot, row, col, self.geo)
        return Action(primitive, rot, row, col, pose, int(explored), eps, q, gmax, goal, goal_color)

    def label(self, obs: EnvObservation, action: Action, result: StepResult,
              nxt: EnvObservation) -> tuple[Transition, bool]:
        """The transition and its reward (DESIGN.md section 7; grasps relabelled in hindsight), and whether the
        action succeeded. A push's reward compares Q_g before and after on the nets this collector acts with."""
        hm, goal = obs.heightmap, action.goal
        rot, row, col = action.rotation, action.row, action.col
        if action.primitive == "grasp":
            # hindsight relabelling: the goal of this grasp is the object under the executed pixel
            pixel_color = qtensor.color_at(hm, row, col)
            reward = rewards.grasp_reward(result.grasped_color is not None and result.grasped_color == pixel_color)
            success = result.target_grasped if action.goal_color else result.grasped_color is not None
            mask = target_mask(hm.color, hm.valid, pixel_color) if pixel_color else goal
            return Transition(hm.color, hm.height, mask, "grasp", rot, row, col, reward), success
        nmask = target_mask(nxt.heightmap.color, nxt.heightmap.valid, obs.target)
        q_after = qtensor.q_maps(self.nets, nxt.heightmap, nmask, ("grasp",))
        changed = scene_change.scene_changed(hm, nxt.heightmap, goal, radius_m=scene_change.PUSH_CHANGE_RADIUS_M)
        occ = [rewards.occupancy_ratio(h, m, 0.05, 0.01) for h, m in ((hm, goal), (nxt.heightmap, nmask))]
        reward = rewards.push_reward(action.grasp_max, qtensor.masked_max(q_after["grasp"], nmask), changed, occ[0],
                                     occ[1])
        t = Transition(hm.color, hm.height, goal, "push", rot, row, col, reward, nxt.heightmap.color,
                       nxt.heightmap.height, nmask, done=False)
        return t, reward > 0


class LocalCollector:
    """The serial source of transitions: one Collector in this process, stepped when the learner asks (the paper's
    loop). Same interface as `pg_learning.training.ray_collectors.RayCollectors`."""

    def __init__(self, collector: Collector) -> None:
        self.collector = collector

    def __enter__(self) -> LocalCollector:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def next(self, iteration: int) -> tuple[Transition, dict[str, Any], int]:
        """The next (transition, log row, collector index 0), acted on at learner `iteration`."""
        return (*self.collector.step(iteration), 0)

    def broadcast(self, state_dicts: dict[str, dict[str, torch.Tensor]], iteration: int) -> None:
        """Nothing to send: the collector acts with the learner's own nets."""

    def close(self) -> None:
        self.collector.close()
