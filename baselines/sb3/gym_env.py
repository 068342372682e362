"""The whole team as one gymnasium agent (centralised control), built from the same slot observations.

It exists so SB3's own `check_env` (which only accepts `gymnasium.Env`) can vet the observation encoding, space
bounds, dtypes and reset/step contract the vector env relies on, and so single-agent libraries can be pointed
at the task.  Observation: the R slot observations concatenated, (R * (7 + R),); action: MultiDiscrete([3]*R).
"""
from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from mahn_envs.core.batch import BatchSim
from mahn_envs.core.params import TaskParams

from ..vec_env import N_SENSOR_INPUTS, slot_observations


class PatrolReturnTeamEnv(gym.Env):
    """One episode; the agent picks all R robots' actions.  Ends by truncation after `max_cycles` ticks."""

    metadata = {"render_modes": []}

    def __init__(self, map: str = "plus", params: TaskParams | None = None, reward_scale: float = 1.0,
                 **task_kwargs: Any) -> None:
        params = params if params is not None else TaskParams(**task_kwargs)
        self.sim = BatchSim(map, 1, params)
        R = self.sim.n_robots
        self.reward_scale = float(reward_scale)
        self.observation_space = spaces.Box(0.0, 1.0, (R * (N_SENSOR_INPUTS + R),), np.float32)
        self.action_space = spaces.MultiDiscrete([3] * R)
        self._episode = 0
        self._sim_seed = 0

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        super().reset(seed=seed)
        if seed is not None:
            self._sim_seed, self._episode = int(seed), 0
        elif self._episode == 0 and self._sim_seed == 0:
            self._sim_seed = int(self.np_random.integers(0, 2**31 - 1))
        obs = self.sim.reset(seed=self._sim_seed, episode_keys=[self._episode])
        self._episode += 1
        return slot_observations(obs).reshape(-1).copy(), {}

    def step(self, action):
        a = np.asarray(action, dtype=np.int64).reshape(1, self.sim.n_robots)
        obs, reward, solved = self.sim.step(a)
        truncated = self.sim.done
        info: dict[str, Any] = {}
        if truncated:
            info = {"team_fitness": float(self.sim.prev_fit[0]), "solved": bool(solved[0])}
        return (slot_observations(obs).reshape(-1).copy(), float(reward[0]) * self.reward_scale, False,
                truncated, info)
