"""Evaluation protocols as pluggable functions: (team policy, map, task params, episodes, seed) -> scores.

`training` is the protocol evolution trains on (all robots signalled at tick `signal_tick`), run here on the batch
core so B episodes go in lock-step.  `sequential` (the paper's real-world protocol: robots called home one at a time,
robots see and bump each other, pymunk engine) is owned by `mahn_evo.evaluation.protocols`; we delegate to it so RL
and evolution are scored by the same code.  Every team (evolved, RL, scripted on the training protocol) implements
:class:`mahn_envs.policies.team_policy.TeamPolicy`.  Register more protocols with `register_protocol`.
"""
from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from mahn_envs.core.batch import BatchSim
from mahn_envs.core.params import TaskParams
from mahn_envs.policies.team_policy import TeamPolicy
from mahn_evo.evaluation import protocols as evo_protocols


@dataclass
class Scores:
    """Per-episode team fitness and `solved`, the metric of `mahn-evo eval`."""

    fitness: np.ndarray
    solved: np.ndarray

    def summary(self) -> dict[str, Any]:
        f = np.asarray(self.fitness, dtype=np.float64)
        s = np.asarray(self.solved, dtype=bool)
        return {"fitness": float(f.mean()), "fitness_std": float(f.std()), "fitness_min": float(f.min()),
                "fitness_max": float(f.max()), "solved": bool(s.all()), "solved_rate": float(s.mean()),
                "episodes": int(f.size), "episode_fitness": [float(v) for v in f],
                "episode_solved": [bool(v) for v in s]}


ProtocolFn = Callable[[TeamPolicy, str, TaskParams, int, int], Scores]


def training_protocol(policy: TeamPolicy, map: str, params: TaskParams, episodes: int, seed: int) -> Scores:
    """All robots get the come-home signal at `params.signal_tick`; episodes run in one batch."""
    sim = BatchSim(map, episodes, params)
    obs = sim.reset(seed=seed)
    policy.reset(episodes)
    while not sim.done:
        obs, _, _ = sim.step(policy.act_batch(obs.copy()))
    fitness, solved = sim.team_fitness()
    return Scores(fitness, solved)


def sequential_protocol(policy: TeamPolicy, map: str, params: TaskParams, episodes: int, seed: int) -> Scores:
    """Delegates to `mahn_evo.evaluation.protocols.sequential(policy, map=, params=, episodes=, seed=)`, which
    drives the policy's dict form (`reset()`, `act({agent: obs})`) and returns per-episode fitness and solved."""
    result = evo_protocols.sequential(policy, map=map, params=params, episodes=episodes, seed=seed)
    get = result.get if isinstance(result, dict) else (lambda k: getattr(result, k))
    return Scores(np.atleast_1d(np.asarray(get("fitness"), dtype=np.float64)),
                  np.atleast_1d(np.asarray(get("solved"), dtype=bool)))


PROTOCOLS: dict[str, ProtocolFn] = {"training": training_protocol, "sequential": sequential_protocol}


def register_protocol(name: str, fn: ProtocolFn) -> None:
    PROTOCOLS[name] = fn


def get_protocol(name: str) -> ProtocolFn:
    if name not in PROTOCOLS:
        raise ValueError(f"unknown protocol {name!r}; known: {sorted(PROTOCOLS)}")
    return PROTOCOLS[name]


def run_protocol(name: str, policy: TeamPolicy, map: str, params: TaskParams | None = None,
                 episodes: int = 1, seed: int = 0) -> Scores:
    return get_protocol(name)(policy, map, params if params is not None else TaskParams(), episodes, seed)
