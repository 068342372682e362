"""Sexual reproduction (SharpNEAT 1.0 rules, no mutation afterwards).

- Matching genes (same innovation id) take their weight 50/50 from either parent.
- Disjoint and excess genes come from the fitter parent.  The less-fit parent's are added only if one coin per
  mating (p = ``disjoint_excess_recombine_probability``, 0.1) succeeds, and then only those whose (src, dst) pair the
  child does not have yet: two genomes can hold the same pair under different ids (the innovation tables are
  per generation), and a genome must never hold a pair twice.
- Equal fitness picks the "fitter" parent at random.
- Hidden neurons and modules come along as the inherited connections require.
"""

from __future__ import annotations

import numpy as np

from .genome import Genome
from .settings import NeatSettings

__all__ = ["crossover"]


def crossover(
    parent1: Genome,
    fitness1: float,
    parent2: Genome,
    fitness2: float,
    rng: np.random.Generator,
    settings: NeatSettings,
) -> Genome:
    """One child of two parents (see the module docstring for the rules)."""
    if fitness1 > fitness2:
        a, b = parent1, parent2
    elif fitness2 > fitness1:
        a, b = parent2, parent1
    else:
        a, b = (parent1, parent2) if rng.random() < 0.5 else (parent2, parent1)
    combine = rng.random() < settings.reproduction.disjoint_excess_recombine_probability

    _, ia, ib = np.intersect1d(a.innov, b.innov, assume_unique=True, return_indices=True)
    w = a.weight.copy()
    if ia.size:
        take_b = rng.random(ia.size) < 0.5
        w[ia[take_b]] = b.weight[ib[take_b]]
    if not combine:
        return a.with_weights(w)

    extra = np.ones(b.n_connections, dtype=bool)
    extra[ib] = False
    cand = np.flatnonzero(extra)
    if cand.size:
        cand = cand[~np.isin(b.pair_keys()[cand], a.pair_keys())]
    a_modules = {m.id for m in a.modules}
    new_modules = tuple(m for m in b.modules if m.id not in a_modules)
    if cand.size == 0 and not new_modules:
        return a.with_weights(w)

    have = a.node_ids
    need = set(b.src[cand].tolist()) | set(b.dst[cand].tolist())
    for m in new_modules:
        need.update(m.inputs)
        need.update(m.outputs)
    b_nodes = {n.id: n for n in b.nodes}
    nodes = a.nodes + tuple(b_nodes[i] for i in sorted(need - have))
    return Genome(
        nodes,
        np.concatenate((a.innov, b.innov[cand])),
        np.concatenate((a.src, b.src[cand])),
        np.concatenate((a.dst, b.dst[cand])),
        np.concatenate((w, b.weight[cand])),
        a.modules + new_modules,
    )
