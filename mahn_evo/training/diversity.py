"""Behavioural diversity: a selection bonus for teams that end their episodes unlike the rest of their generation.

The task's fitness is deceptive. Most unsolved runs sit for hundreds of generations on a plateau (fitness 50-62)
where every post is patrolled and two robots return, while the third stays at its post or stalls on the way
(docs/results/screen/). The step off that plateau changes one robot's return brain and gains almost nothing until
the robot reaches home, so selection by fitness alone has nothing to follow.
Behavioural diversity (Mouret and Doncieux, 2012; the population-only form of novelty search, Lehman and
Stanley, 2011) rewards a team by how far its behaviour lies from its k nearest neighbours in the same generation.
The behaviour is where the three robots end their episodes, which is what separates the plateau's teams from each
other and from solved ones. NEAT then selects by ``fitness + weight * diversity``. The task's own fitness still
decides the champion, the archive, "solved" and the logs.

The bonus depends on the current generation only, so it adds no state to checkpoints: a resumed run recomputes it
bit for bit.
"""
from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

__all__ = ["behavioural_diversity", "selection_fitness"]


def behavioural_diversity(behaviour: np.ndarray, k: int) -> np.ndarray:
    """Each row's mean Euclidean distance to its `k` nearest other rows (k is capped at N - 1; 0 for N = 1).

    Identical teams (elites, clones) are each other's nearest neighbours at distance 0, so a generation full of
    copies earns no bonus.
    """
    b = np.asarray(behaviour, dtype=np.float64).reshape(len(behaviour), -1)
    if isinstance(k, bool) or not isinstance(k, (int, np.integer)) or k < 1:
        raise ValueError(f"k must be a positive integer, got {k!r}")
    n = b.shape[0]
    k = min(int(k), n - 1)
    if k < 1:
        return np.zeros(n)
    dist, _ = cKDTree(b).query(b, k=k + 1)
    # every row finds itself (distance 0) among its k + 1 nearest; with duplicates any one of the zeros is dropped
    return np.sort(dist, axis=1)[:, 1:].mean(axis=1)


def selection_fitness(fitness: np.ndarray, behaviour: np.ndarray, weight: float, k: int) -> np.ndarray:
    """What NEAT selects by: the fitness plus `weight` times the behavioural diversity (the fitness itself when
    `weight` is 0, so a run without diversity is bit-identical to one from before this option)."""
    if weight == 0:
        return fitness
    return fitness + weight * behavioural_diversity(behaviour, k)
