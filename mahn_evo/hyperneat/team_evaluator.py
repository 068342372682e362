"""Team evaluation through the batch core: a whole generation of CPPNs -> controllers -> fitness, in one call.

Decoding is vectorised over the population (substrate.py) and the episodes run in the compiled parallel loop
with the controllers inside, so a generation of 500 teams costs one kernel call.
"""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from mahn_envs.core import BatchSim, TaskParams
from mahn_envs.maps import load_map
from mahn_envs.policies.team_controllers import TeamControllers

from ..cppn import CPPN_ACTIVATIONS, compile_genome
from .substrate import decode_population

#: How a team's fitness is taken from its episodes: "fixed" draws (episode keys 0..K-1 every generation) or fresh
#: draws per generation (keys g*K .. g*K+K-1, the same for every team of generation g: common random numbers).
NOISE_DRAWS = ("fixed", "per_generation")
#: How the K episode fitnesses of a team become its fitness.
AGGREGATES = ("mean", "min", "quantile")


@dataclass
class Evaluation:
    fitness: np.ndarray  # (N,) team fitness: the episodes' fitness aggregated (mean, min or a quantile)
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
    """Scores genomes as teams on one map.  Deterministic: episodes are keyed, not drawn from shared state.

    Robust evaluation: with noise in `params`, `episodes` = K > 1 and ``noise_draws="per_generation"`` every team
    of a generation meets the same K noisy episodes (common random numbers: teams are compared on equal luck) and
    each generation meets new ones (a team cannot be selected for one lucky draw); ``aggregate`` "min" or
    "quantile" scores a team by its bad episodes rather than its mean.
    """

    def __init__(self, mode: str, map: str = "plus", params: TaskParams | None = None, episodes: int = 1,
                 seed: int = 0, evaluate_modules: bool = False, cppn_activation: str = "recursive",
                 noise_draws: str = "fixed", aggregate: str = "mean", quantile: float = 0.25,
                 noise_free_episode: bool = False) -> None:
        self.mode = mode
        self.world = load_map(map)
        self.params = params if params is not None else TaskParams()
        if episodes < 1:
            raise ValueError(f"episodes must be >= 1, got {episodes}")
        self.episodes = episodes
        self.seed = seed
        self.evaluate_modules = evaluate_modules
        if cppn_activation not in CPPN_ACTIVATIONS:
            raise ValueError(f"cppn_activation must be one of {CPPN_ACTIVATIONS}, got {cppn_activation!r}")
        if noise_draws not in NOISE_DRAWS:
            raise ValueError(f"noise_draws must be one of {NOISE_DRAWS}, got {noise_draws!r}")
        if aggregate not in AGGREGATES:
            raise ValueError(f"aggregate must be one of {AGGREGATES}, got {aggregate!r}")
        if not 0.0 <= quantile <= 1.0:
            raise ValueError(f"quantile must be in [0, 1], got {quantile!r}")
        self.cppn_activation = cppn_activation
        self.noise_draws = noise_draws
        self.aggregate = aggregate
        self.quantile = quantile
        #: also score every team on one noise-free episode (aggregated with the noisy ones): a team must work with
        #: and without noise, instead of relying on noise to get out of a deadlock
        self.noise_free_episode = bool(noise_free_episode)
        self._sims: dict[int, BatchSim] = {}
        self._clean_sims: dict[int, BatchSim] = {}

    def decode(self, genomes: Sequence) -> TeamControllers:
        plans = [compile_genome(g, self.cppn_activation, self.evaluate_modules) for g in genomes]
        return decode_population(plans, self.mode, self.world.n_robots)

    def _sim(self, n: int) -> BatchSim:
        if n not in self._sims:
            self._sims = {n: BatchSim(self.world, n, self.params)}
        return self._sims[n]

    def _clean_sim(self, n: int) -> BatchSim:
        if n not in self._clean_sims:
            self._clean_sims = {n: BatchSim(self.world, n, self.params.without_noise())}
        return self._clean_sims[n]

    def episode_keys(self, generation: int = 0) -> list[int]:
        """The keys of the episodes every team of `generation` is scored on."""
        first = generation * self.episodes if self.noise_draws == "per_generation" else 0
        return list(range(first, first + self.episodes))

    def score(self, controllers: TeamControllers, generation: int = 0) -> tuple[np.ndarray, np.ndarray]:
        """Aggregated fitness and solved fraction of each team over its keyed episodes.

        Teams whose controllers are identical (elites carried over, duplicate offspring, genomes that decode to
        the same weights) are run once: every team meets the same keyed episodes, so their results are equal.
        """
        ctrl = controllers.as_batch()
        first, index = distinct_teams(ctrl)
        if len(first) < ctrl.w_ih.shape[0]:
            ctrl = TeamControllers(*(np.ascontiguousarray(getattr(ctrl, f)[first]) for f in CONTROLLER_FIELDS))
        n = ctrl.w_ih.shape[0]
        sim = self._sim(n)
        keys = self.episode_keys(generation)
        fits = np.zeros((len(keys) + self.noise_free_episode, n))
        solved = np.zeros(n)
        for e, key in enumerate(keys):
            res = sim.run_controllers(ctrl, seed=self.seed, episode_keys=np.full(n, key))
            fits[e] = res.fitness
            solved += res.solved
        if self.noise_free_episode:
            res = self._clean_sim(n).run_controllers(ctrl, seed=self.seed, episode_keys=np.zeros(n, dtype=np.int64))
            fits[-1] = res.fitness
            solved += res.solved
        if self.aggregate == "min":
            fit = fits.min(axis=0)
        elif self.aggregate == "quantile":
            fit = np.quantile(fits, self.quantile, axis=0)
        else:  # the mean, summed in episode order (as before: bit-identical for old runs)
            fit = np.zeros(n)
            for e in range(fits.shape[0]):
                fit += fits[e]
            fit = fit / fits.shape[0]
        return fit[index], solved[index] / fits.shape[0]

    def evaluate(self, genomes: Sequence, generation: int = 0) -> Evaluation:
        controllers = self.decode(genomes)
        fitness, solved = self.score(controllers, generation)
        return Evaluation(fitness, solved, controllers)
