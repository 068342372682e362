"""The one interface every team policy implements, so every protocol runs any team.

Evolved teams (:class:`mahn_envs.policies.ControllerPolicy`), RL policies (``baselines.sb3.policy.SB3TeamPolicy``,
``baselines.lean.nets.LeanTeamPolicy``) all offer both forms a protocol may need:

- ``reset(n_episodes=1)``: start ``n_episodes`` fresh episodes (network or recurrent state cleared);
- ``act_batch(obs)``: observations ``(B, R, 7)`` of B lock-step episodes -> actions ``(B, R)`` (the batch core's
  form, used by the training protocol);
- ``act(observations)``: the PettingZoo dict form ``{agent: (7,)} -> {agent: action}`` for one episode (used by
  the sequential protocol, which runs in the PettingZoo env; agents missing from the dict are skipped).

Batch-first policies get ``act`` from :class:`DictActFromBatch`, so the dict form is written once.  (The scripted
team of :mod:`mahn_envs.policies.scripted` drives from poses, which no learned policy sees; it is the one exception and
says so with ``uses_infos = True``.)
"""
from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Protocol, runtime_checkable

import numpy as np


@runtime_checkable
class TeamPolicy(Protocol):
    """What the protocols drive; see the module docstring."""

    def reset(self, n_episodes: int = 1) -> None: ...

    def act_batch(self, obs: np.ndarray) -> np.ndarray: ...

    def act(self, observations: Mapping[str, np.ndarray]) -> dict[str, int]: ...


class DictActFromBatch:
    """``act`` (one episode, PettingZoo dicts) written once on top of a policy's ``act_batch``."""

    agents: Sequence[str]
    n_robots: int

    def act_batch(self, obs: np.ndarray) -> np.ndarray:  # pragma: no cover - implemented by the policy
        raise NotImplementedError

    def act(self, observations: Mapping[str, np.ndarray]) -> dict[str, int]:
        obs = np.zeros((1, self.n_robots, 7), dtype=np.float32)
        for r, agent in enumerate(self.agents):
            if agent in observations:
                obs[0, r] = observations[agent]
        actions = self.act_batch(obs)[0]
        return {agent: int(actions[r]) for r, agent in enumerate(self.agents) if agent in observations}
