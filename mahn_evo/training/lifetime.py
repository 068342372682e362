"""Lifetime fitness under noise: a team's score is the mean over every generation it has been scored in.

Why: in a robust phase each generation scores every team on a few fresh noisy episodes (K = 3 or 4), and one robot
that misses home costs the episode its 100-point solved bonus, so a team that fails in 5 % of episodes and one
that fails in 1 % are told apart by luck.  NEAT carries its elites into the next generation unchanged, so a team
that stays in the population is scored again each generation on new draws; averaging those scores
(re-evaluation averaging, the standard remedy for noisy fitness) makes the fitness of a long-lived team an
estimate from many episodes, while a newcomer competes with its one generation's score.  The leader the archive
keeps is the best team that solved every episode of at least LIFETIME_MIN_GENERATIONS generations, not the
luckiest one of a generation (docs/results/transfer_failures/: 4 of 5 robust teams need each robot to complete each
stage in about 99 % of episodes).

A team is its genome's content (`genome_key`, what decoding reads): equal genomes are the same team and share one
record.  Records are kept only for the genomes of the current generation, and saved in the checkpoint aligned with
the next generation's genomes, which are the only ones ever looked up again.
"""
from __future__ import annotations

import hashlib
from collections.abc import Hashable, Sequence
from typing import Any

import numpy as np

from ..hyperneat.memo import genome_key
from ..neat.genome import Genome

#: "generation" (a team's fitness is its score in this generation, as the paper), "lifetime" (the mean of its
#: scores over the generations it has been scored in, under noise; see this module) or "archive" (NEAT selects by
#: the generation's score, as with "generation", and only the archive keeps lifetime leaders: the two parts of
#: "lifetime" apart)
FITNESS_MEMORY = ("generation", "lifetime", "archive")
#: generations a team must have been scored in (solving every episode of each) before the archive keeps it
LIFETIME_MIN_GENERATIONS = 3


def genome_digest(genome: Genome) -> str:
    """A stable name of a genome's content (sha256 of its `genome_key`), for files and checkpoints."""
    return hashlib.sha256(repr(genome_key(genome)).encode()).hexdigest()


class LifetimeScores:
    """Sum of scores, generations scored and whether every episode was solved, per team of the current
    generation."""

    def __init__(self) -> None:
        self._records: dict[Hashable, tuple[float, int, bool]] = {}

    def update(self, genomes: Sequence[Genome], fitness: np.ndarray, solved: np.ndarray
               ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Add this generation's scores (fitness, solved: every episode solved) -> per genome (lifetime mean,
        generations scored, solved in all of them).  Equal genomes in one generation played the same episodes
        and count once; records of genomes not in this generation are forgotten."""
        current: dict[Hashable, tuple[float, int, bool]] = {}
        out = np.zeros((3, len(genomes)))
        for i, g in enumerate(genomes):
            key = genome_key(g)
            rec = current.get(key)
            if rec is None:
                total, n, ok = self._records.get(key, (0.0, 0, True))
                rec = current[key] = (total + float(fitness[i]), n + 1, ok and bool(solved[i]))
            out[:, i] = rec[0] / rec[1], rec[1], rec[2]
        self._records = current
        return out[0], out[1].astype(np.int64), out[2].astype(bool)

    def clear(self) -> None:
        self._records = {}

    def to_list(self, genomes: Sequence[Genome]) -> list[Any]:
        """The records of `genomes` (the next generation), aligned with them: [sum, generations, all solved] or
        None for a genome not scored yet."""
        out: list[Any] = []
        for g in genomes:
            rec = self._records.get(genome_key(g))
            out.append(None if rec is None else [rec[0], rec[1], rec[2]])
        return out

    @classmethod
    def from_list(cls, genomes: Sequence[Genome], rows: Any) -> LifetimeScores:
        """The inverse of `to_list`; a malformed list raises ValueError naming the problem."""
        if not isinstance(rows, list) or len(rows) != len(genomes):
            raise ValueError(f"'lifetime' must be a list of {len(genomes)} entries, one per genome")
        scores = cls()
        for g, row in zip(genomes, rows):
            if row is None:
                continue
            if not (isinstance(row, list) and len(row) == 3 and isinstance(row[0], (int, float))
                    and not isinstance(row[0], bool) and isinstance(row[1], int) and not isinstance(row[1], bool)
                    and row[1] >= 1 and isinstance(row[2], bool) and np.isfinite(row[0])):
                raise ValueError(f"'lifetime' entries must be [score sum, generations >= 1, all solved], got {row!r}")
            scores._records[genome_key(g)] = (float(row[0]), row[1], row[2])
        return scores
