"""A trained SB3 model as a *team policy*: the interface evaluation protocols drive.

A protocol only needs `reset(n_episodes)` and `act_batch(obs (B, R, 7)) -> actions (B, R)`; for protocols
written around PettingZoo envs and evolved teams (`mahn_envs.policies.ControllerPolicy`) the adapter also offers
the same `reset()` / `act({agent: obs}) -> {agent: action}` methods, so RL policies and evolved teams can be
scored by one protocol implementation.
"""
from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from mahn_envs.policies.team_policy import DictActFromBatch

from ..vec_env import slot_observations


class SB3TeamPolicy(DictActFromBatch):
    """Shared-parameter SB3 policy acting for every robot; keeps LSTM state for recurrent models."""

    def __init__(self, model: Any, n_robots: int = 3, deterministic: bool = True,
                 agents: Sequence[str] | None = None) -> None:
        self.model = model
        self.n_robots = int(n_robots)
        self.deterministic = deterministic
        self.agents = list(agents) if agents is not None else [f"robot_{k}" for k in range(self.n_robots)]
        self._state: Any = None
        self._episode_start: np.ndarray | None = None
        self._n_episodes = 0

    def reset(self, n_episodes: int = 1) -> None:
        """Start fresh episodes: recurrent state is cleared (episode_start = 1 at the next call)."""
        self._n_episodes = int(n_episodes)
        self._state = None
        self._episode_start = np.ones(self._n_episodes * self.n_robots, dtype=bool)

    def act_batch(self, obs: np.ndarray) -> np.ndarray:
        B, R, _ = obs.shape
        if self._episode_start is None or B != self._n_episodes:
            self.reset(B)
        x = slot_observations(np.asarray(obs, dtype=np.float32))
        actions, self._state = self.model.predict(x, state=self._state, episode_start=self._episode_start,
                                                  deterministic=self.deterministic)
        self._episode_start = np.zeros(B * R, dtype=bool)
        return np.asarray(actions, dtype=np.int64).reshape(B, R)
