"""A Stable-Baselines3 vector env over the batch simulation core: every robot of every episode is one slot.

Why not SuperSuit over the PettingZoo env?  That route steps one Python env per episode and builds dicts every
tick; here one call into the compiled core advances all B episodes x R robots, so the simulator stops being the
bottleneck of RL training (see `benchmarks/bench_vec_env.py`).  It also gets SB3's contract right where
SuperSuit does not: time-outs are reported as truncation (`TimeLimit.truncated`), and seeding goes through
SB3's own `VecEnv.seed` (used by `model = PPO(..., seed=S)`).

This module is numpy-only, so `baselines` imports without torch.  It implements the whole `VecEnv` interface
by duck typing; `register_with_sb3()` (called by the SB3-using modules) makes it a virtual subclass of SB3's
`VecEnv` ABC, so SB3 algorithms and wrappers accept it unchanged.

Slot layout: slot `b * R + r` is robot r of episode b.  Its observation is the core's 7 inputs (six IR values,
then the come-home signal) followed by a one-hot agent index, so one shared policy can still give each robot its
own role (the evolved teams get the same information as their policy-geometry coordinate z_k).
All episodes run in lock-step and have the same fixed length (`max_cycles` ticks), so every slot ends an episode
at the same step: all slots report done together, with `terminal_observation` and `TimeLimit.truncated=True`
in their infos, and the batch is reset at once -- exactly SB3's auto-reset semantics.
"""
from __future__ import annotations

import time
from collections.abc import Iterable, Sequence
from copy import deepcopy
from typing import Any

import numpy as np
from gymnasium import spaces

from mahn_envs.core import task as T
from mahn_envs.core.batch import BatchSim
from mahn_envs.core.params import TaskParams

N_SENSOR_INPUTS = 7  #: six IR values then the come-home signal (the core's observation)

Indices = None | int | Iterable[int]

#: per-robot columns of `PatrolReturnVecEnv.global_state`
GLOBAL_ROBOT_FEATURES = ("x", "y", "sin_heading", "cos_heading", "signal", "turned", "reached_home",
                         "distance_home_at_signal", "return_credit")


def global_state_size(n_robots: int, n_pois: int) -> int:
    """Width of `PatrolReturnVecEnv.global_state`: time, the robots' features, post coverage, two team flags."""
    return 1 + n_robots * len(GLOBAL_ROBOT_FEATURES) + n_pois + 2


def slot_observations(core_obs: np.ndarray, out: np.ndarray | None = None) -> np.ndarray:
    """Core observations (B, R, 7) -> slot observations (B*R, 7+R): the inputs then a one-hot agent index.

    Shared by the vector env, the evaluation policy adapter and the PettingZoo example so that a policy sees
    identical inputs wherever it runs.
    """
    B, R, _ = core_obs.shape
    if out is None:
        out = np.zeros((B, R, N_SENSOR_INPUTS + R), dtype=np.float32)
        out[:, np.arange(R), N_SENSOR_INPUTS + np.arange(R)] = 1.0
    else:
        out = out.reshape(B, R, N_SENSOR_INPUTS + R)
    out[:, :, :N_SENSOR_INPUTS] = core_obs
    return out.reshape(B * R, N_SENSOR_INPUTS + R)


class PatrolReturnVecEnv:
    """SB3 `VecEnv` of `n_episodes` lock-stepped episodes x R robots (num_envs = n_episodes * R).

    Rewards: every slot of an episode gets that episode's shared team reward times `reward_scale` (a constant
    scale keeps the optimal policy and keeps the value targets in a range SB3's defaults handle).  The `episode`
    info written at the end of an episode (read by SB3's logger as
    `rollout/ep_rew_mean`) is always the unscaled team fitness, the paper's score, so TensorBoard curves compare
    directly with evolution; infos then also carry `team_fitness` and `solved`.

    Seeding: `seed(s)` (what SB3 calls for `seed=s`) fixes the next `reset`; the sim seed is s and episode n of
    slot-batch b uses the core's episode key n * n_episodes + b, so every episode has its own noise stream
    (only relevant with noise or start jitter; the default task is deterministic).
    """

    def __init__(self, n_episodes: int = 16, map: str = "plus", params: TaskParams | None = None,
                 reward_scale: float = 1.0, validate_actions: bool = True, **task_kwargs: Any) -> None:
        if params is not None and task_kwargs:
            raise ValueError("give either params=TaskParams(...) or task keyword arguments, not both")
        params = params if params is not None else TaskParams(**task_kwargs)
        if not np.isfinite(reward_scale) or reward_scale <= 0:
            raise ValueError(f"reward_scale must be a finite positive number, got {reward_scale!r}")
        self.sim = BatchSim(map, n_episodes, params)
        self.map_name = self.sim.world.name
        self.n_episodes = int(n_episodes)
        self.n_robots = self.sim.n_robots
        self.reward_scale = float(reward_scale)
        self.validate_actions = validate_actions
        R = self.n_robots
        self.num_envs = self.n_episodes * R
        self.observation_space = spaces.Box(0.0, 1.0, (N_SENSOR_INPUTS + R,), np.float32)
        self.action_space = spaces.Discrete(3)
        self.render_mode = None
        self.metadata: dict[str, Any] = {"render_modes": []}
        self.reset_infos: list[dict[str, Any]] = [{} for _ in range(self.num_envs)]
        self._seeds: list[int | None] = [None] * self.num_envs
        self._options: list[dict[str, Any]] = [{} for _ in range(self.num_envs)]
        self._obs = np.zeros((self.n_episodes, R, N_SENSOR_INPUTS + R), dtype=np.float32)
        self._obs[:, np.arange(R), N_SENSOR_INPUTS + np.arange(R)] = 1.0
        self._actions: np.ndarray | None = None
        self._seed: int | None = None
        self._episode = 0  # episodes started since the last seeding
        self._t_start = time.perf_counter()
        self._needs_reset = True

    # ------------------------------------------------------------------ seeding and reset
    @property
    def params(self) -> TaskParams:
        return self.sim.params

    def seed(self, seed: int | None = None) -> Sequence[int | None]:
        """SB3 semantics: the seeds apply at the next `reset`; slot i nominally gets seed + i."""
        if seed is None:
            seed = int(np.random.randint(0, np.iinfo(np.uint32).max, dtype=np.uint32))
        if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
            raise ValueError(f"seed must be a non-negative integer, got {seed!r}")
        self._seeds = [int(seed) + i for i in range(self.num_envs)]
        return self._seeds

    def set_options(self, options: list[dict] | dict | None = None) -> None:
        """Stored for API compatibility; the batch core takes no per-slot reset options."""
        if options is None:
            options = {}
        self._options = deepcopy([options] * self.num_envs) if isinstance(options, dict) else deepcopy(options)

    def _start_batch(self) -> np.ndarray:
        first = self._episode * self.n_episodes
        keys = range(first, first + self.n_episodes)  # episode n of slot-batch b: key n * n_episodes + b
        assert self._seed is not None  # reset() / reset_at() set it before any batch starts
        core_obs = self.sim.reset(seed=self._seed, episode_keys=keys)
        self._episode += 1
        self._t_start = time.perf_counter()
        return slot_observations(core_obs, self._obs)

    def reset(self) -> np.ndarray:
        if self._seeds[0] is not None:
            self._seed = int(self._seeds[0])
            self._episode = 0
        elif self._seed is None:  # never seeded: draw one, as gymnasium envs do
            self._seed = int(np.random.randint(0, np.iinfo(np.int32).max))
        self._seeds = [None] * self.num_envs
        self._options = [{} for _ in range(self.num_envs)]
        self.reset_infos = [{} for _ in range(self.num_envs)]
        self._needs_reset = False
        return self._start_batch().copy()

    def reset_at(self, seed: int, episode: int) -> np.ndarray:
        """Start batch number `episode` of seed `seed` (what `seed(seed); reset()` then `episode` finished
        batches would give): how a resumed training run continues the episode sequence it stopped in."""
        if isinstance(episode, bool) or not isinstance(episode, (int, np.integer)) or episode < 0:
            raise ValueError(f"episode must be a non-negative integer, got {episode!r}")
        self.seed(seed)
        self.reset()
        self._episode = int(episode)
        return self._start_batch().copy()

    @property
    def tick(self) -> int:
        """Ticks played in the current batch of episodes (0 right after a reset)."""
        return self.sim.tick

    @property
    def global_state_size(self) -> int:
        return global_state_size(self.n_robots, self.sim.goto.shape[1])

    def global_state(self, out: np.ndarray | None = None) -> np.ndarray:
        """The team's state as a centralised critic sees it: (n_episodes, global_state_size) float32.

        Columns: time (tick / max_cycles); per robot x, y (scaled to the map's extent), sin and cos of the
        heading, its come-home signal, turned-since-signal and reached-home flags, distance to home at the
        signal and return credit so far (both / 100 cm); patrol credit per post (/ fitness samples before
        the signal); then the two team flags (every post covered at the signal, signal given).  That is
        everything the fitness depends on, so with it the value of a state is a function of the state:
        the reward multipliers (all posts covered, everyone moved) are no longer hidden from the critic.
        Read-only view of the batch core's arrays; actors never see it.
        """
        sim, p = self.sim, self.sim.params
        B, R = self.n_episodes, self.n_robots
        if out is None:
            out = np.empty((B, self.global_state_size), dtype=np.float32)
        xmin, ymin, xmax, ymax = sim.world.bounds
        feats = np.empty((B, R, len(GLOBAL_ROBOT_FEATURES)), dtype=np.float32)
        feats[:, :, 0] = (sim.pose[:, :, T.X] - xmin) / (xmax - xmin)
        feats[:, :, 1] = (sim.pose[:, :, T.Y] - ymin) / (ymax - ymin)
        feats[:, :, 2] = np.sin(sim.pose[:, :, T.H])
        feats[:, :, 3] = np.cos(sim.pose[:, :, T.H])
        feats[:, :, 4] = sim.rflag[:, :, T.F_SIGNAL]
        feats[:, :, 5] = sim.rflag[:, :, T.F_TURNED]
        feats[:, :, 6] = sim.rflag[:, :, T.F_REACH]
        feats[:, :, 7] = sim.racc[:, :, T.R_ORIG_DIST] / 100.0
        feats[:, :, 8] = sim.racc[:, :, T.R_END] / 100.0
        out[:, 0] = sim.tick / p.max_cycles
        out[:, 1:1 + feats[0].size] = feats.reshape(B, -1)
        n_samples = max(1, p.signal_tick // p.sample_period)
        P = sim.goto.shape[1]
        out[:, 1 + feats[0].size:1 + feats[0].size + P] = sim.goto / n_samples
        out[:, -2] = sim.est[:, T.E_ALLCLOSE]
        out[:, -1] = sim.est[:, T.E_SWITCHED]
        return out

    # ------------------------------------------------------------------ stepping
    def step_async(self, actions: np.ndarray) -> None:
        self._actions = actions

    def step_wait(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, list[dict[str, Any]]]:
        if self._needs_reset:
            raise RuntimeError("call reset() before step()")
        a = np.asarray(self._actions)
        if a.shape not in ((self.num_envs,), (self.num_envs, 1)):
            raise ValueError(f"expected {self.num_envs} actions (one per slot), got shape {a.shape}")
        a = a.reshape(self.n_episodes, self.n_robots)
        if self.validate_actions:
            a = self.sim.check_actions(a)
        elif a.dtype != np.int64:
            a = a.astype(np.int64)
        core_obs, team_reward, solved = self.sim.step(a, validate=False)
        rewards = np.repeat((team_reward * self.reward_scale).astype(np.float32), self.n_robots)
        obs = slot_observations(core_obs, self._obs)
        if not self.sim.done:
            return obs.copy(), rewards, np.zeros(self.num_envs, dtype=bool), [{} for _ in range(self.num_envs)]
        infos = self._final_infos(obs)
        self.reset_infos = [{} for _ in range(self.num_envs)]
        return self._start_batch().copy(), rewards, np.ones(self.num_envs, dtype=bool), infos

    def _final_infos(self, obs: np.ndarray) -> list[dict[str, Any]]:
        fitness, solved = self.sim.team_fitness()
        elapsed = round(time.perf_counter() - self._t_start, 6)
        length = self.sim.tick
        infos = []
        for i in range(self.num_envs):
            b = i // self.n_robots
            f = float(fitness[b])
            infos.append({"terminal_observation": obs[i].copy(), "TimeLimit.truncated": True,
                          "team_fitness": f, "solved": bool(solved[b]),
                          "episode": {"r": f, "l": length, "t": elapsed}})
        return infos

    def step(self, actions: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, list[dict[str, Any]]]:
        self.step_async(actions)
        return self.step_wait()

    # ------------------------------------------------------------------ rest of the VecEnv interface
    def close(self) -> None:
        pass

    def get_images(self) -> Sequence[np.ndarray | None]:
        return [None] * self.num_envs

    def render(self, mode: str | None = None) -> None:
        return None

    def _get_indices(self, indices: Indices) -> Iterable[int]:
        if indices is None:
            return range(self.num_envs)
        if isinstance(indices, (int, np.integer)):
            return [int(indices)]
        return indices

    def has_attr(self, attr_name: str) -> bool:
        return hasattr(self, attr_name)

    def get_attr(self, attr_name: str, indices: Indices = None) -> list[Any]:
        """Slots share one simulator, so every slot reports the env's attribute."""
        value = getattr(self, attr_name)
        return [value for _ in self._get_indices(indices)]

    def set_attr(self, attr_name: str, value: Any, indices: Indices = None) -> None:
        setattr(self, attr_name, value)

    def env_method(self, method_name: str, *method_args: Any, indices: Indices = None,
                   **method_kwargs: Any) -> list[Any]:
        method = getattr(self, method_name)
        return [method(*method_args, **method_kwargs) for _ in self._get_indices(indices)]

    def env_is_wrapped(self, wrapper_class: type, indices: Indices = None) -> list[bool]:
        return [False for _ in self._get_indices(indices)]

    @property
    def unwrapped(self) -> PatrolReturnVecEnv:
        return self

    def getattr_depth_check(self, name: str, already_found: bool) -> str | None:
        if hasattr(self, name) and already_found:
            return f"{type(self).__module__}.{type(self).__name__}"
        return None


def register_with_sb3() -> None:
    """Make `PatrolReturnVecEnv` a virtual subclass of SB3's `VecEnv` ABC (imports SB3, hence torch)."""
    from stable_baselines3.common.vec_env import VecEnv

    if not issubclass(PatrolReturnVecEnv, VecEnv):
        VecEnv.register(PatrolReturnVecEnv)
