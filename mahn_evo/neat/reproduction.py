"""Selection, target sizes, elitism, stagnation and offspring production for one generation.

Original rules (section 8) and the deliberate deviations:

- target_s is proportional to the species' mean fitness (times 0.01 if it stagnated for more than 200 generations;
  the champion species is exempt).  The original rounds each target independently, so the population drifts;
  here targets are apportioned by **largest remainder** (ties to the earlier species), so they sum exactly to the
  population size.  The champion species always gets a target of at least 1 (taken from the largest species),
  and an elite of at least 1, so the best genome always survives *(choice: with deterministic evaluation the best
  fitness can then never decrease)*.
- elite_s = min(size_s, floor(0.2 * target_s)), or 1 if that is 0 and target_s > 1.
- offspring = target - elite (exact, again so the size never drifts); asexual = max(1, round(offspring * 0.5))
  (capped at offspring), the rest sexual.  Python's ``round`` is round-half-even, like C#'s Math.Round.
- parents are roulette-selected (fitness-proportionate, one clean wheel) among the best round(0.8 * size) members;
  interspecies mates (p = 0.01) are drawn from the union of every species' selection pool.
- crossover children are not mutated (original).  ``crossover_mutation_probability`` > 0 (not the original; NEAT
  2002 uses 0.8) gives such a child one mutation from the same roulette as the asexual offspring.
- population stagnation (not the original, off by default; NEAT 2002): see :func:`top_two_targets`.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from .crossover import crossover
from .genome import Genome
from .innovation import InnovationTracker
from .mutation import mutate
from .roulette import spin_cumulative
from .settings import NeatSettings
from .speciation import Species

__all__ = ["apportion", "target_sizes", "top_two_targets", "elite_sizes", "Offspring", "make_offspring"]


def apportion(shares: np.ndarray, total: int) -> np.ndarray:
    """Integers proportional to ``shares`` summing exactly to ``total`` (largest-remainder method).

    Remainders are handed out by decreasing fractional part; ties go to the earlier entry.
    """
    s = np.asarray(shares, dtype=np.float64)
    if s.size == 0:
        return np.zeros(0, dtype=np.int64)
    tot = s.sum()
    if not (tot > 0 and np.all(s >= 0) and np.all(np.isfinite(s))):
        raise ValueError("apportion: shares must be finite, non-negative and not all 0")
    quotas = s / tot * total
    base = np.floor(quotas).astype(np.int64)
    rem = int(total - base.sum())
    frac = quotas - base
    order = np.argsort(-frac, kind="stable")
    while rem > 0:  # rem < size in exact arithmetic; loop guards against rounding
        take = order[: min(rem, order.size)]
        base[take] += 1
        rem -= take.size
    while rem < 0:  # only possible through rounding of quotas
        i = int(np.argmax(base))
        base[i] -= 1
        rem += 1
    return base


def target_sizes(adjusted_means: np.ndarray, champion: int, total: int) -> np.ndarray:
    """Species target sizes summing to ``total``; the champion species gets at least 1."""
    t = apportion(adjusted_means, total)
    if t[champion] == 0:
        donor = int(np.argmax(t))
        t[donor] -= 1
        t[champion] = 1
    return t


def top_two_targets(species_best: np.ndarray, champion: int, total: int) -> np.ndarray:
    """NEAT 2002's population-stagnation rule: only the two best species reproduce, half the population each.

    The champion species is always one of them; the other is the best of the rest by best member fitness (ties to
    the earlier species).  With a single species it gets everything.
    """
    t = np.zeros(len(species_best), dtype=np.int64)
    if len(species_best) == 1:
        t[0] = total
        return t
    rest = [k for k in range(len(species_best)) if k != champion]
    second = max(rest, key=lambda k: (float(species_best[k]), -k))
    t[champion] = total - total // 2
    t[second] = total // 2
    return t


def elite_sizes(targets: np.ndarray, sizes: np.ndarray, champion: int, elitism: float) -> np.ndarray:
    """Members kept unchanged per species (see module docstring)."""
    e = np.minimum(sizes, np.floor(targets * elitism).astype(np.int64))
    e = np.where((e == 0) & (targets > 1), 1, e)
    e[champion] = max(int(e[champion]), 1)
    return np.minimum(e, targets)


@dataclass(frozen=True)
class Offspring:
    """A new genome and the ids of the species its parents came from (placement tries them first)."""

    genome: Genome
    parent_species: tuple[int, ...]


def _pool_size(size: int, proportion: float) -> int:
    return max(1, int(round(size * proportion)))


def make_offspring(
    species: Sequence[Species],
    genomes: Sequence[Genome],
    fitness: np.ndarray,
    targets: np.ndarray,
    elites: np.ndarray,
    rng: np.random.Generator,
    settings: NeatSettings,
    tracker: InnovationTracker,
) -> list[Offspring]:
    """All offspring of one generation: every species' asexual ones first, then every species' sexual ones.

    ``species[i].members`` must be sorted best first; ``targets``/``elites`` are aligned with ``species``.
    """
    pools: list[list[int]] = []
    cums: list[np.ndarray] = []
    for sp in species:
        pool = sp.members[: _pool_size(len(sp.members), settings.selection.selection_proportion)]
        pools.append(pool)
        cums.append(np.cumsum(fitness[pool]))
    all_pool = [i for p in pools for i in p]
    all_cum = np.cumsum(fitness[all_pool]) if all_pool else np.zeros(0)
    species_of = {i: sp.id for sp in species for i in sp.members}

    n_asex: list[int] = []
    n_sex: list[int] = []
    for t, e in zip(targets.tolist(), elites.tolist()):
        off = t - e
        a = min(off, max(1, int(round(off * settings.reproduction.asexual_proportion)))) if off > 0 else 0
        n_asex.append(a)
        n_sex.append(off - a)

    tracker.new_generation()
    out: list[Offspring] = []

    def asexual(k: int) -> Offspring:
        parent = pools[k][spin_cumulative(cums[k], rng)]
        return Offspring(mutate(genomes[parent], rng, settings, tracker), (species[k].id,))

    for k in range(len(species)):
        for _ in range(n_asex[k]):
            out.append(asexual(k))

    for k, sp in enumerate(species):
        members = sp.members
        for _ in range(n_sex[k]):
            if rng.random() < settings.reproduction.interspecies_mating_probability:
                p1 = pools[k][spin_cumulative(cums[k], rng)]
                p2 = all_pool[spin_cumulative(all_cum, rng)]
            elif len(members) == 1:
                out.append(asexual(k))
                continue
            elif len(members) == 2:
                p1, p2 = members[0], members[1]
            else:
                p1 = pools[k][spin_cumulative(cums[k], rng)]
                p2 = p1
                for _ in range(5):
                    p2 = pools[k][spin_cumulative(cums[k], rng)]
                    if p2 != p1:
                        break
                if p2 == p1:
                    out.append(asexual(k))
                    continue
            child = crossover(genomes[p1], float(fitness[p1]), genomes[p2], float(fitness[p2]), rng, settings)
            p_mutate = settings.reproduction.crossover_mutation_probability
            if p_mutate > 0.0 and rng.random() < p_mutate:
                child = mutate(child, rng, settings, tracker)
            out.append(Offspring(child, (sp.id, species_of[p2]) if species_of[p2] != sp.id else (sp.id,)))
    return out


def stagnation_adjusted_means(
    species: Sequence[Species],
    fitness: np.ndarray,
    champion: int,
    generation: int,
    settings: NeatSettings,
) -> np.ndarray:
    """Mean fitness per species, times the stagnation penalty for stagnant species: with stagnation_rule
    "recompute" every non-champion species now stagnant, with "sticky" every flagged one (see Population.tell)."""
    means = np.array([float(np.mean(fitness[sp.members])) for sp in species])
    for k, sp in enumerate(species):
        if settings.selection.stagnation_rule == "sticky":
            stagnant = sp.culled
        else:
            stagnant = k != champion and generation - sp.last_improvement > settings.selection.stagnation_generations
        if stagnant:
            means[k] *= settings.selection.stagnation_penalty
    if not np.any(means > 0):  # every species penalised to 0 cannot happen with a positive floor; guard anyway
        means = np.ones_like(means)
    return means

