"""Speciation: compatibility distance, species records, placement rules and the dynamic threshold.

Rules (original system, section 8):

- distance = c_disjoint * #disjoint + c_excess * #excess + c_weight * SUM |dw| over matching genes (a sum, no
  normalisation by genome size; ``weight_difference_mean`` uses the mean instead, as NEAT 2002 does); a genome is
  compatible with a species if distance < threshold;
- a species' representative is its current first member (after trimming: its best elite; during a full
  re-speciation: the first genome placed in it);
- an offspring tries its parent species 1, then parent species 2, then every other species in order (by id, or with
  ``species_order = "random"`` in a seeded pseudo-random order fixed per species id, see :func:`order_keys`), and
  founds a new species if none is compatible;
- the threshold steers the species count into a target range; any adjustment, or a change of mean complexity by
  more than 5 % since the last one, triggers a full re-speciation.

Deviations on purpose: species are kept in a list ordered by id (the original used a hash table), and during a full
re-speciation a new species takes over the identity (id, age, best fitness, last improvement) of the old species
its founding genome came from, if no earlier new species has claimed it *(choice: keeps ids stable in logs and
keeps the stagnation rule meaningful even though the threshold moves, and so re-speciates, most generations)*.

Distances to all representatives are computed at once: representatives are stored as rows of a dense matrix over
the union of the population's innovation ids, so one genome costs a few numpy calls whatever the species count.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from .genome import Genome
from .settings import NeatSettings

__all__ = [
    "Species",
    "compatibility_distance",
    "RepresentativeIndex",
    "ThresholdController",
    "speciate_all",
    "order_keys",
]


def compatibility_distance(a: Genome, b: Genome, settings: NeatSettings) -> float:
    """Distance between two genomes (scalar reference; the population uses :class:`RepresentativeIndex`).

    Excess genes are the genes of one genome whose innovation id exceeds the other genome's largest one; the
    other non-matching genes are disjoint.  With one genome empty, all genes of the other are excess.
    """
    common, ia, ib = np.intersect1d(a.innov, b.innov, assume_unique=True, return_indices=True)
    m = common.size
    max_a = int(a.innov[-1]) if a.n_connections else -1
    max_b = int(b.innov[-1]) if b.n_connections else -1
    excess = int(np.count_nonzero(a.innov > max_b)) + int(np.count_nonzero(b.innov > max_a))
    disjoint = a.n_connections + b.n_connections - 2 * m - excess
    wsum = float(np.sum(np.abs(a.weight[ia] - b.weight[ib]))) if m else 0.0
    if settings.speciation.weight_difference_mean and m:
        wsum /= m
    return (settings.speciation.disjoint_coefficient * disjoint + settings.speciation.excess_coefficient * excess
            + settings.speciation.weight_coefficient * wsum)


@dataclass
class Species:
    """A species: stable id, member indices (into the population list, best first once sorted), history."""

    id: int
    members: list[int]
    created: int  # generation the species was founded
    best_fitness: float = -math.inf  # best fitness ever seen in the species
    last_improvement: int = 0  # generation of the last improvement of best_fitness
    culled: bool = False  # flagged as stagnant for good (stagnation_rule "sticky" only)

    def to_dict(self) -> dict[str, Any]:
        d: dict[str, Any] = {
            "id": self.id,
            "members": list(self.members),
            "created": self.created,
            "best_fitness": None if self.best_fitness == -math.inf else self.best_fitness,
            "last_improvement": self.last_improvement,
        }
        if self.culled:  # only the sticky stagnation rule sets it; files of the other rule stay as they were
            d["culled"] = True
        return d

    def successor(self, members: list[int]) -> Species:
        """The same species (identity and history) with new members."""
        return Species(self.id, members, self.created, self.best_fitness, self.last_improvement, self.culled)

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> Species:
        bf = d.get("best_fitness")
        return cls(
            int(d["id"]),
            [int(i) for i in d["members"]],
            int(d["created"]),
            -math.inf if bf is None else float(bf),
            int(d["last_improvement"]),
            bool(d.get("culled", False)),
        )


class RepresentativeIndex:
    """Representatives as rows of a dense weight matrix over a fixed set of innovation ids (columns).

    Every genome later passed to :meth:`distances` must only use innovation ids from ``genomes`` given here.
    """

    def __init__(self, genomes: Sequence[Genome], settings: NeatSettings) -> None:
        self.settings = settings
        arrays = [g.innov for g in genomes]
        self.cols = np.unique(np.concatenate(arrays)) if arrays else np.zeros(0, dtype=np.int64)
        self.k = 0
        self._cap = 0
        u = self.cols.size
        self._w = np.zeros((0, u))
        self._p = np.zeros((0, u), dtype=bool)
        self._n = np.zeros(0, dtype=np.int64)
        self._max = np.zeros(0, dtype=np.int64)
        self._same_coeff = settings.speciation.disjoint_coefficient == settings.speciation.excess_coefficient

    def _grow(self) -> None:
        cap = max(16, 2 * self._cap)
        u = self.cols.size
        w = np.zeros((cap, u))
        p = np.zeros((cap, u), dtype=bool)
        n = np.zeros(cap, dtype=np.int64)
        mx = np.zeros(cap, dtype=np.int64)
        w[: self.k] = self._w[: self.k]
        p[: self.k] = self._p[: self.k]
        n[: self.k] = self._n[: self.k]
        mx[: self.k] = self._max[: self.k]
        self._w, self._p, self._n, self._max, self._cap = w, p, n, mx, cap

    def add(self, g: Genome) -> int:
        """Append g as the representative of the next species row; returns the row."""
        if self.k == self._cap:
            self._grow()
        idx = np.searchsorted(self.cols, g.innov)
        self._w[self.k, idx] = g.weight
        self._p[self.k, idx] = True
        self._n[self.k] = g.n_connections
        self._max[self.k] = g.innov[-1] if g.n_connections else -1
        self.k += 1
        return self.k - 1

    def distances(self, g: Genome) -> np.ndarray:
        """Distance from g to every representative row, shape (k,)."""
        s = self.settings
        k = self.k
        if k == 0:
            return np.zeros(0)
        idx = np.searchsorted(self.cols, g.innov)
        pk = self._p[:k, idx]
        m = pk.sum(axis=1)
        wsum = (np.abs(self._w[:k, idx] - g.weight) * pk).sum(axis=1)
        if s.speciation.weight_difference_mean:
            wsum = wsum / np.maximum(m, 1)
        n_g = g.n_connections
        nonmatch = n_g + self._n[:k] - 2 * m
        if self._same_coeff:
            return s.speciation.disjoint_coefficient * nonmatch + s.speciation.weight_coefficient * wsum
        max_g = int(g.innov[-1]) if n_g else -1
        excess_g = n_g - np.searchsorted(g.innov, self._max[:k], side="right")
        j0 = int(np.searchsorted(self.cols, max_g, side="right"))
        excess_r = self._p[:k, j0:].sum(axis=1)
        excess = excess_g + excess_r
        return (s.speciation.disjoint_coefficient * (nonmatch - excess) + s.speciation.excess_coefficient * excess
                + s.speciation.weight_coefficient * wsum)


_MIX1 = np.uint64(0xBF58476D1CE4E5B9)
_MIX2 = np.uint64(0x94D049BB133111EB)
_GOLDEN = np.uint64(0x9E3779B97F4A7C15)


def order_keys(species_ids: Sequence[int] | np.ndarray, salt: int) -> np.ndarray:
    """Pseudo-random, seeded sort keys of species ids (splitmix64 of id + salt): the ``"random"`` species order.

    Why keyed by id rather than a fresh shuffle: the original iterates a Hashtable keyed by species id, whose order
    is unrelated to age but stays the same for the same species from one generation to the next.
    """
    with np.errstate(over="ignore"):
        z = np.asarray(species_ids, dtype=np.uint64) * _GOLDEN + np.uint64(salt % 2**64)
        z = (z ^ (z >> np.uint64(30))) * _MIX1
        z = (z ^ (z >> np.uint64(27))) * _MIX2
        return z ^ (z >> np.uint64(31))


def first_compatible(d: np.ndarray, threshold: float, preferred: Sequence[int],
                     keys: np.ndarray | None = None) -> int:
    """Row to join: the first compatible preferred row, else the first compatible row in order (rows in order,
    or by ascending ``keys[row]`` when given), else -1."""
    for r in preferred:
        if r >= 0 and d[r] < threshold:
            return r
    ok = np.flatnonzero(d < threshold)
    if not ok.size:
        return -1
    if keys is None:
        return int(ok[0])
    return int(ok[np.argmin(keys[ok])])


def speciate_all(
    genomes: Sequence[Genome],
    threshold: float,
    settings: NeatSettings,
    old_species: Sequence[Species],
    generation: int,
    next_species_id: int,
    parents: Sequence[Sequence[int]] = (),
    order_salt: int | None = None,
) -> tuple[list[Species], int]:
    """Full re-speciation of ``genomes`` in list order; returns (species ordered by id, next free species id).

    A new species inherits the identity of the old species its founder belonged to (first claim wins); otherwise
    it gets a fresh id.  With ``parents`` (per genome, the species ids of its parents), a genome first tries those
    of its parents' species that have been formed so far, then every species in order (by id, or by
    :func:`order_keys` with ``order_salt``).
    """
    owner: dict[int, Species] = {}
    for sp in old_species:
        for i in sp.members:
            owner[i] = sp
    claimed: set[int] = set()
    index = RepresentativeIndex(genomes, settings)
    species: list[Species] = []
    row_of: dict[int, int] = {}  # species id -> row
    keys: list[int] = []
    for i, g in enumerate(genomes):
        preferred = [row_of.get(pid, -1) for pid in parents[i]] if parents else ()
        r = first_compatible(index.distances(g), threshold, preferred,
                             None if order_salt is None else np.asarray(keys, dtype=np.uint64))
        if r >= 0:
            species[r].members.append(i)
            continue
        old = owner.get(i)
        if old is not None and old.id not in claimed:
            claimed.add(old.id)
            sp = old.successor([i])
        else:
            sp = Species(next_species_id, [i], generation, -math.inf, generation)
            next_species_id += 1
        row_of[sp.id] = len(species)
        species.append(sp)
        if order_salt is not None:
            keys.append(int(order_keys([sp.id], order_salt)[0]))
        index.add(g)
    species.sort(key=lambda s: s.id)
    return species, next_species_id


class ThresholdController:
    """Moves the compatibility threshold to keep the species count within the target range.

    On starting an adjustment the step is +-max(delta_min, proportion * threshold); it grows by ``acceleration``
    while the direction stays the same and is multiplied by ``-deceleration`` when the count overshoots to the
    other side.  When the count is in range the step is reset to 0, so the next adjustment starts afresh
    *(inference: the sheet describes the start, growth and reversal of the step, not its fate in range)*.
    The threshold never goes below ``threshold_floor``.
    """

    def __init__(self, threshold: float, delta: float = 0.0) -> None:
        self.threshold = float(threshold)
        self.delta = float(delta)

    def adjust(self, n_species: int, settings: NeatSettings) -> bool:
        """Update the threshold for ``n_species``; True if it changed (a full re-speciation is then due)."""
        lo, hi = settings.species_target_range
        if n_species < lo:
            direction = -1.0
        elif n_species > hi:
            direction = 1.0
        else:
            self.delta = 0.0
            return False
        if self.delta == 0.0:
            self.delta = direction * max(settings.speciation.threshold_delta_min,
                                         settings.speciation.threshold_delta_proportion * self.threshold)
        elif (self.delta > 0) == (direction > 0):
            self.delta *= settings.speciation.threshold_delta_acceleration
        else:
            self.delta *= -settings.speciation.threshold_delta_deceleration
        new = max(settings.speciation.threshold_floor, self.threshold + self.delta)
        changed = new != self.threshold
        self.threshold = new
        return changed

    def to_dict(self) -> dict[str, float]:
        return {"threshold": self.threshold, "delta": self.delta}

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> ThresholdController:
        return cls(float(d["threshold"]), float(d["delta"]))
