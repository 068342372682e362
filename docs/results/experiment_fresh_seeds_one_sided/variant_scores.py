"""Noise-free training-protocol scores of champion files on ten branch variants of plus of each kind: one-sided
(`--branch-sides one`, B = 49), one-sided with the raised arm shorter by its offset (`one_short`, B = 49) and
both-sided (`both`, B = 40).  Prints, per file and kind, the variants solved and the mean score.

The variants are those of episode keys 0-9 of a run seeded 999 (`mahn_envs.maps.variants.spread_variant`), the
same for every file, so the rows compare.

Usage: python variant_scores.py CHAMPION.json [...]
"""
from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

from mahn_envs.core import BatchSim, TaskParams
from mahn_envs.maps.variants import spread_variant
from mahn_evo.training.champion import Champion

KINDS = (("one", 49.0), ("one_short", 49.0), ("both", 40.0))


def variant_scores(path: Path, variants: int = 10, seed: int = 999) -> dict[str, tuple[int, float]]:
    """{kind: (variants solved, mean fitness)} of the champion at `path`."""
    controllers = Champion.load(path).controllers
    out = {}
    for sides, branch in KINDS:
        fits = [float(BatchSim(spread_variant(seed, key, 0.0, branch, sides), 1, TaskParams())
                      .run_controllers(controllers, episode_keys=np.zeros(1, dtype=np.int64)).fitness[0])
                for key in range(variants)]
        out[sides] = (sum(f > 100 for f in fits), round(float(np.mean(fits)), 1))
    return out


if __name__ == "__main__":
    for name in sys.argv[1:]:
        print(name, variant_scores(Path(name)), flush=True)
