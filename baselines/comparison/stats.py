"""Statistics of the comparison across runs: interquartile mean with a bootstrap confidence interval
(rliable's recommendation for few runs) and Fisher's exact test of solved rates against a reference method.

numpy / scipy only; the bootstrap draws from a seeded generator, so a table is reproducible.
"""
from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from scipy import stats


def iqm(values: Sequence[float] | np.ndarray) -> float:
    """Interquartile mean: the mean of the middle 50% (scipy's trim_mean with 25% cut at each end)."""
    v = np.asarray(values, dtype=np.float64)
    if v.size == 0:
        raise ValueError("iqm of no values")
    return float(stats.trim_mean(v, 0.25))


def iqm_ci(values: Sequence[float] | np.ndarray, confidence: float = 0.95, resamples: int = 2000,
           seed: int = 0) -> tuple[float, float]:
    """Percentile bootstrap interval of the IQM over runs (runs resampled with replacement)."""
    v = np.asarray(values, dtype=np.float64)
    if v.size == 0:
        raise ValueError("iqm_ci of no values")
    if not 0 < confidence < 1:
        raise ValueError(f"confidence must be in (0, 1), got {confidence}")
    rng = np.random.default_rng(seed)
    samples = v[rng.integers(0, v.size, size=(resamples, v.size))]
    boot = stats.trim_mean(samples, 0.25, axis=1)
    lo, hi = np.quantile(boot, [(1 - confidence) / 2, (1 + confidence) / 2])
    return float(lo), float(hi)


def fisher_solved(solved_a: int, runs_a: int, solved_b: int, runs_b: int) -> float:
    """Two-sided p-value of Fisher's exact test: are the solved rates of two methods different?"""
    for name, (k, n) in {"a": (solved_a, runs_a), "b": (solved_b, runs_b)}.items():
        if n < 1 or not 0 <= k <= n:
            raise ValueError(f"method {name}: solved {k} of {n} runs is not a valid count")
    return float(stats.fisher_exact([[solved_a, runs_a - solved_a], [solved_b, runs_b - solved_b]])[1])
