"""Run a team of evolved controllers on PettingZoo-style observation dicts, one tick at a time.

Used by `mahn-evo eval` in the env, by the hardware env and by examples.  It calls the same compiled network
function as the batch core, so a team behaves identically in every place it runs.
"""
from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np

from .controllers import TeamControllers
from .core.controller import network_action, transposed


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
        self._weights = transposed(self.controllers)
        self.agents = list(agents)
        n_hidden = controllers.w_hh.shape[-1]
        R = len(agents)
        self._obs = np.zeros((1, R, 7), dtype=np.float32)
        self._hid = np.zeros((1, R, n_hidden), dtype=np.float32)
        self._out = np.zeros((1, R, 3), dtype=np.float32)
        self._brain = np.zeros((1, R), dtype=np.int64)
        self._tmp = np.zeros(n_hidden + 3, dtype=np.float32)

    def reset(self) -> None:
        self._hid[:] = 0.0
        self._out[:] = 0.0
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

    def act(self, observations: Mapping[str, np.ndarray]) -> dict[str, int]:
        actions = {}
        for r, agent in enumerate(self.agents):
            if agent not in observations:
                continue
            self._obs[0, r] = observations[agent]
            sig = 1 if self._obs[0, r, 6] > 0.5 else 0
            a = network_action(0, r, self._obs, sig, *self._weights, self._hid, self._out, self._brain, self._tmp)
            actions[agent] = int(a) if a <= 2 else 1  # NaN outputs cannot occur with finite weights
        return actions
