"""How far a solved team's weights can move: each substrate array (and the CPPN's weights) perturbed by Gaussian
noise of a given size, the perturbed teams played noise-free on plus (the training protocol, the compiled core).

  python docs/results/polish/sensitivity.py CHAMPION > sensitivity.csv

One row per (array, size): the median fitness and the solved fraction of 30 perturbed copies (seed 0); only the
nonzero entries of a substrate array are perturbed (the substrate's connectivity stays), and the CPPN's
perturbed weights are decoded as the champion's run decoded them.
"""
from __future__ import annotations

import csv
import sys

import numpy as np

from mahn_envs.core import BatchSim
from mahn_envs.policies.team_controllers import _FIELDS, TeamControllers
from mahn_evo.cppn import compile_genome
from mahn_evo.hyperneat.substrate import decode_population, team_reading
from mahn_evo.neat.settings import MutationSettings
from mahn_evo.training.champion import Champion, champion_decoding

SIZES = (1e-5, 1e-4, 1e-3, 3e-3, 1e-2)
COPIES = 30


def perturbed_substrate(c: TeamControllers, which: str, size: float, rng: np.random.Generator) -> TeamControllers:
    arrays = {f: np.repeat(getattr(c, f)[None], COPIES, 0).astype(np.float64) for f in _FIELDS}
    a = arrays[which]
    a += size * rng.standard_normal(a.shape) * (a != 0)
    return TeamControllers(**arrays, decision=c.decision)


def perturbed_cppn(champ: Champion, size: float, rng: np.random.Generator) -> TeamControllers:
    activation, modules, reading = champion_decoding(champ)
    limit = MutationSettings().weight_limit
    plans = [compile_genome(champ.genome.with_weights(np.clip(
        champ.genome.weight + size * rng.standard_normal(len(champ.genome.weight)), -limit, limit)),
        activation, modules) for _ in range(COPIES)]
    return team_reading(decode_population(plans, champ.mode, champ.controllers.n_robots), reading).with_decision(
        champ.controllers.decision)


def main(argv: list[str]) -> int:
    if len(argv) != 1:
        print(__doc__, file=sys.stderr)
        return 2
    champ = Champion.load(argv[0])
    sim = BatchSim(champ.map, COPIES, champ.task())
    rng = np.random.default_rng(0)
    out = csv.writer(sys.stdout)
    out.writerow(["array", "size", "median_fitness", "solved_fraction"])
    for size in SIZES:
        for which in (*_FIELDS, "cppn"):
            teams = perturbed_cppn(champ, size, rng) if which == "cppn" else \
                perturbed_substrate(champ.controllers, which, size, rng)
            r = sim.run_controllers(teams, seed=1)
            out.writerow([which, size, round(float(np.median(r.fitness)), 1), round(float(r.solved.mean()), 3)])
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
