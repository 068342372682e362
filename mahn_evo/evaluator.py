"""Team evaluation through the batch core: a whole generation of CPPNs -> controllers -> fitness, in one call.

Decoding is vectorised over the population (substrate.py) and the episodes run in the compiled parallel loop
with the controllers inside, so a generation of 500 teams costs one kernel call.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Optional, Sequence

import numpy as np

from mahn_envs.controllers import TeamControllers
from mahn_envs.core import BatchSim, TaskParams
from mahn_envs.maps import load_map

from .cppn import compile_cppn
from .substrate import decode_population


@dataclass
class Evaluation:
    fitness: np.ndarray  # (N,) mean team fitness over the episodes
    solved: np.ndarray  # (N,) fraction of episodes solved
    controllers: TeamControllers  # batch (N, R, K, ...)


CONTROLLER_FIELDS = ("w_ih", "w_hh", "w_ho", "b_h", "b_o")


def distinct_teams(ctrl: TeamControllers) -> tuple[np.ndarray, np.ndarray]:
    """(first, index): `first` lists one team of each distinct set of controller arrays (in order of first
    appearance) and team i equals team first[index[i]].  Teams are compared bit for bit (float32 patterns)."""
    n = ctrl.w_ih.shape[0]
    rows = np.concatenate([np.ascontiguousarray(getattr(ctrl, f), dtype=np.float32).reshape(n, -1)
                           for f in CONTROLLER_FIELDS], axis=1)
    seen: dict[bytes, int] = {}
    first: list[int] = []
    index = np.empty(n, dtype=np.int64)
    for i in range(n):
        key = rows[i].tobytes()
        j = seen.get(key)
        if j is None:
            j = seen[key] = len(first)
            first.append(i)
        index[i] = j
    return np.array(first, dtype=np.int64), index


class TeamEvaluator:
    """Scores genomes as teams on one map.  Deterministic: episodes are keyed, not drawn from shared state."""

    def __init__(self, mode: str, map: str = "plus", params: Optional[TaskParams] = None, episodes: int = 1,
                 seed: int = 0, evaluate_modules: bool = False) -> None:
        self.mode = mode
        self.world = load_map(map)
        self.params = params if params is not None else TaskParams()
        if episodes < 1:
            raise ValueError(f"episodes must be >= 1, got {episodes}")
        self.episodes = episodes
        self.seed = seed
        self.evaluate_modules = evaluate_modules
        self._sims: dict[int, BatchSim] = {}

    def decode(self, genomes: Sequence) -> TeamControllers:
        plans = [compile_cppn(g, evaluate_modules=self.evaluate_modules) for g in genomes]
        return decode_population(plans, self.mode, self.world.n_robots)

    def _sim(self, n: int) -> BatchSim:
        if n not in self._sims:
            self._sims = {n: BatchSim(self.world, n, self.params)}
        return self._sims[n]

    def score(self, controllers: TeamControllers) -> tuple[np.ndarray, np.ndarray]:
        """Mean fitness and solved fraction of each team over `episodes` keyed episodes.

        Teams whose controllers are identical (elites carried over, duplicate offspring, genomes that decode to
        the same weights) are run once: every team meets the same keyed episodes, so their results are equal.
        """
        ctrl = controllers.as_batch()
        first, index = distinct_teams(ctrl)
        if len(first) < ctrl.w_ih.shape[0]:
            ctrl = TeamControllers(*(np.ascontiguousarray(getattr(ctrl, f)[first]) for f in CONTROLLER_FIELDS))
        n = ctrl.w_ih.shape[0]
        sim = self._sim(n)
        fit = np.zeros(n)
        solved = np.zeros(n)
        for e in range(self.episodes):
            res = sim.run_controllers(ctrl, seed=self.seed, episode_keys=np.full(n, e))
            fit += res.fitness
            solved += res.solved
        return fit[index] / self.episodes, solved[index] / self.episodes

    def evaluate(self, genomes: Sequence) -> Evaluation:
        controllers = self.decode(genomes)
        fitness, solved = self.score(controllers)
        return Evaluation(fitness, solved, controllers)
