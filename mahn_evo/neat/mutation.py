"""Asexual reproduction: exactly one mutation per offspring, as in the original.

The operator is chosen by a roulette over (add node, add connection, weights).  Structural operators that cannot
apply (no connection to split, or no free (src, dst) pair within the allowed attempts) fall back to a weight
mutation, so an asexual offspring always differs from its parent in some way unless the genome has no connections.
"""

from __future__ import annotations

import numpy as np

from .genome import Genome, NodeGene
from .innovation import InnovationTracker
from .roulette import spin
from .settings import NeatSettings

__all__ = ["mutate", "mutate_weights", "add_node", "add_connection"]

_JIGGLE_SCHEMES = (0, 1, 2)
_PROPORTIONAL = {0: 0, 1: 1, 3: 2}  # scheme -> index into settings.mutation.weight_scheme_proportions


def mutate(genome: Genome, rng: np.random.Generator, settings: NeatSettings, tracker: InnovationTracker) -> Genome:
    """Return a child of ``genome`` with exactly one mutation applied."""
    m = settings.mutation
    op = spin((m.add_node_probability, m.add_connection_probability, m.mutate_weights_probability), rng)
    child: Genome | None = None
    if op == 0:
        child = add_node(genome, rng, settings, tracker)
    elif op == 1:
        child = add_connection(genome, rng, settings, tracker)
    if child is None:
        child = mutate_weights(genome, rng, settings)
    return child


def mutate_weights(genome: Genome, rng: np.random.Generator, settings: NeatSettings) -> Genome:
    """One of five weight schemes (jiggle each p=0.5 / each p=0.1 / one; reset each p=0.1 / one).

    In the proportional schemes, if no connection was selected one random connection is mutated instead, so the
    operator never silently does nothing.  Jiggles are clamped to +-weight_limit; resets draw U(-limit, limit).
    """
    n = genome.n_connections
    if n == 0:
        return genome
    scheme = spin(settings.mutation.weight_scheme_probabilities, rng)
    if scheme in _PROPORTIONAL:
        p = settings.mutation.weight_scheme_proportions[_PROPORTIONAL[scheme]]
        idx = np.flatnonzero(rng.random(n) < p)
        if idx.size == 0:
            idx = np.array([rng.integers(n)], dtype=np.int64)
    else:
        idx = np.array([rng.integers(n)], dtype=np.int64)
    w = genome.weight.copy()
    lim = settings.mutation.weight_limit
    if scheme in _JIGGLE_SCHEMES:
        j = settings.mutation.weight_jiggle
        w[idx] = np.clip(w[idx] + rng.uniform(-j, j, idx.size), -lim, lim)
    else:
        w[idx] = rng.uniform(-lim, lim, idx.size)
    return genome.with_weights(w)


def add_node(
    genome: Genome, rng: np.random.Generator, settings: NeatSettings, tracker: InnovationTracker
) -> Genome | None:
    """Split a random connection a->b with a new hidden node n: add a->n (w=1) and n->b (old weight).

    The split connection is kept (a parallel path), as in the original, unless
    ``settings.mutation.add_node_keeps_split_connection`` is False (then it is removed, as classic NEAT disables it).
    Splitting the same connection twice in
    one generation reuses the node id, its activation and both connection ids.  Returns None if there is no
    connection to split.
    """
    n = genome.n_connections
    if n == 0:
        return None
    k = int(rng.integers(n))
    split = int(genome.innov[k])
    a = int(genome.src[k])
    b = int(genome.dst[k])
    rec = tracker.splits.get(split)
    if rec is None or rec[0] in genome.node_ids:
        acts = settings.mutation.hidden_activations
        act = acts[int(rng.integers(len(acts)))] if len(acts) > 1 else acts[0]
        rec = (tracker.new_id(), act, tracker.new_id(), tracker.new_id())
        tracker.splits.setdefault(split, rec)
    nid, act, cin, cout = rec
    keep = np.ones(n, dtype=bool)
    if not settings.mutation.add_node_keeps_split_connection:
        keep[k] = False
    return Genome(
        genome.nodes + (NodeGene(nid, "hidden", act),),
        np.append(genome.innov[keep], (cin, cout)),
        np.append(genome.src[keep], (a, nid)),
        np.append(genome.dst[keep], (nid, b)),
        np.append(genome.weight[keep], (1.0, genome.weight[k])),
        genome.modules,
    )


def add_connection(
    genome: Genome, rng: np.random.Generator, settings: NeatSettings, tracker: InnovationTracker
) -> Genome | None:
    """Connect a random source to a random target not yet connected; None if every attempt hit an existing pair.

    Sources: every neuron except module-input dummies; targets: outputs and hidden neurons (original rules).
    Recurrent links and self-loops are allowed unless ``settings.mutation.allow_recurrent`` is False.
    """
    info = genome._info
    srcs, tgts = info.sources, info.targets
    if srcs.size == 0 or tgts.size == 0:
        return None
    existing = set(genome.pair_keys().tolist())
    for _ in range(settings.mutation.add_connection_attempts):
        a = int(srcs[rng.integers(srcs.size)])
        b = int(tgts[rng.integers(tgts.size)])
        if (a << 32) + b in existing:
            continue
        if not settings.mutation.allow_recurrent and _creates_cycle(genome, a, b):
            continue
        innov = tracker.connection_id(a, b)
        r = settings.mutation.new_connection_weight_range
        w = rng.uniform(-r, r)
        return Genome(
            genome.nodes,
            np.append(genome.innov, innov),
            np.append(genome.src, a),
            np.append(genome.dst, b),
            np.append(genome.weight, w),
            genome.modules,
            _info=info,
        )
    return None


def _creates_cycle(genome: Genome, a: int, b: int) -> bool:
    """True if adding a->b closes a directed cycle (b reaches a), counting module input->output as edges."""
    if a == b:
        return True
    succ: dict[int, list[int]] = {}
    for s, d in zip(genome.src.tolist(), genome.dst.tolist()):
        succ.setdefault(s, []).append(d)
    for m in genome.modules:
        for i in m.inputs:
            succ.setdefault(i, []).extend(m.outputs)
    stack, seen = [b], {b}
    while stack:
        v = stack.pop()
        for w in succ.get(v, ()):
            if w == a:
                return True
            if w not in seen:
                seen.add(w)
                stack.append(w)
    return False
