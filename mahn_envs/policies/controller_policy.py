"""Run a team of evolved controllers on PettingZoo-style observation dicts, one tick at a time.

Used by `mahn-evo eval` in the env, by the hardware env and by examples.  It calls the same compiled network
function as the batch core, so a team behaves identically in every place it runs.
"""
from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np

from ..core.controller import network_action, transposed
from .team_controllers import TeamControllers


class ControllerPolicy:
    """Stateful team policy: observations {agent: (7,)} -> actions {agent: 0/1/2}.

    The signal is read from observation index 6: situational teams switch to their return brain (fresh
    state) the first tick they see it; standard teams read it as an input.
    """

    def __init__(self, controllers: TeamControllers, agents: Sequence[str]) -> None:
        if controllers.batched:
            raise ValueError("ControllerPolicy takes one team (arrays (R, K, ...)), not a batch")
        if len(agents) != controllers.n_robots:
            raise ValueError(f"{len(agents)} agents for a team of {controllers.n_robots} controllers")
        self.controllers = controllers.as_batch()
        self.agents = list(agents)
        self.n_robots = len(self.agents)
        self._n_hidden = controllers.w_hh.shape[-1]
        self._by_net = controllers.decision == "net_input"
        self._tmp = np.zeros(self._n_hidden + 3, dtype=np.float32)
        self._episodes = 0
        self.reset(1)
        # compile (or load from numba's cache) the network now: a first call compiles, seconds with a cold cache,
        # which inside a real robot's first tick would leave the robots driving on their last command
        self._step(0, 0)
        self.reset(1)

    def reset(self, n_episodes: int = 1) -> None:
        """Start `n_episodes` fresh episodes (state cleared); the same team acts in every one of them."""
        n = int(n_episodes)
        if n < 1:
            raise ValueError(f"n_episodes must be >= 1, got {n_episodes!r}")
        if n != self._episodes:
            # the batch kernel indexes weights by episode, so the one team's weights are repeated per episode
            self._weights = transposed(self.controllers.repeated(n))
            R = self.n_robots
            self._obs = np.zeros((n, R, 7), dtype=np.float32)
            self._hid = np.zeros((n, R, self._n_hidden), dtype=np.float32)
            self._out = np.zeros((n, R, 3), dtype=np.float32)
            self._net = np.zeros((n, R, 3), dtype=np.float32)
            self._brain = np.zeros((n, R), dtype=np.int64)
            self._episodes = n
        self._hid[:] = 0.0
        self._out[:] = 0.0
        self._net[:] = 0.0
        self._brain[:] = 0

    def snapshot(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The networks' state (hidden, outputs, brain), to try an input and go back (see `restore`)."""
        return self._hid.copy(), self._out.copy(), self._brain.copy()

    def restore(self, snapshot: tuple[np.ndarray, np.ndarray, np.ndarray]) -> None:
        self._hid[:], self._out[:], self._brain[:] = snapshot

    @property
    def outputs(self) -> np.ndarray:
        """Last network outputs (R, 3): left, forward, right."""
        return self._out[0].copy()

    @property
    def decision_values(self) -> np.ndarray:
        """The last values (R, 3) the action was chosen from: the outputs, or their net inputs for teams that
        decide by them (TeamControllers.decision)."""
        return (self._net if self._by_net else self._out)[0].copy()

    def act_batch(self, obs: np.ndarray) -> np.ndarray:
        """Observations (B, R, 7) of B lock-step episodes -> actions (B, R); a new B starts B fresh episodes."""
        obs = np.asarray(obs, dtype=np.float32)
        if obs.ndim != 3 or obs.shape[1:] != (self.n_robots, 7):
            raise ValueError(f"act_batch: observations must have shape (B, {self.n_robots}, 7), got {obs.shape}")
        if obs.shape[0] != self._episodes:
            self.reset(obs.shape[0])
        self._obs[:] = obs
        actions = np.empty((self._episodes, self.n_robots), dtype=np.int64)
        for b in range(self._episodes):
            for r in range(self.n_robots):
                actions[b, r] = self._step(b, r)
        return actions

    def act(self, observations: Mapping[str, np.ndarray]) -> dict[str, int]:
        """One episode in PettingZoo dicts (agents missing from the dict, e.g. finished, are skipped)."""
        if self._episodes != 1:
            raise ValueError(f"act() drives one episode; this policy was reset for {self._episodes} "
                             "(call reset() or use act_batch)")
        actions = {}
        for r, agent in enumerate(self.agents):
            if agent not in observations:
                continue
            self._obs[0, r] = observations[agent]
            actions[agent] = self._step(0, r)
        return actions

    def _step(self, b: int, r: int) -> int:
        sig = 1 if self._obs[b, r, 6] > 0.5 else 0
        a = network_action(b, r, self._obs, sig, *self._weights, self._hid, self._out, self._brain, self._tmp,
                           self._by_net)
        self._net[b, r] = self._tmp[self._n_hidden:]
        return int(a) if a <= 2 else 1  # NaN outputs cannot occur with finite weights
