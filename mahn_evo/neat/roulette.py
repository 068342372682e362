"""Fitness-proportionate (roulette-wheel) choice driven by the run's single seeded generator.

Why a helper of our own: the original spun some wheels with an unseeded ``System.Random`` and one over the whole
population list with a truncated total (a quirk).  Every wheel here draws exactly one ``rng.random()`` and walks a
cumulative sum, so runs are bit-reproducible and the draw count never depends on floating-point luck.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np


def spin(weights: Sequence[float] | np.ndarray, rng: np.random.Generator) -> int:
    """Index i with probability weights[i] / sum(weights).  Zero-weight entries are never chosen."""
    w = np.asarray(weights, dtype=np.float64)
    cum = np.cumsum(w)
    total = cum[-1]
    if not total > 0.0:
        raise ValueError("roulette: weights must have a positive sum")
    i = int(np.searchsorted(cum, rng.random() * total, side="right"))
    if i >= w.size:  # r * total rounded up to total: take the last positive entry
        i = int(np.flatnonzero(w > 0)[-1])
    return i


def spin_cumulative(cum: np.ndarray, rng: np.random.Generator) -> int:
    """Like :func:`spin` but with a precomputed cumulative sum of positive weights (faster in loops)."""
    i = int(np.searchsorted(cum, rng.random() * cum[-1], side="right"))
    return min(i, cum.size - 1)
