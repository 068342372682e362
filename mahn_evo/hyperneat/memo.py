"""Exact memos of the evaluator: what a genome decodes to and what a team scores, kept from one generation to the
next.

Why: NEAT carries its elites into the next generation unchanged and breeds duplicates, so about a third of a
generation's genomes were decoded, and their teams scored, one generation before (measured at generation 1000 of a
paper-scale run: 155-159 of 500 genomes seen in the previous generation, 450 distinct).  Decoding is a pure
function of the genome's genes and scoring of the controllers and the keyed episode, so a remembered result is the
result, bit for bit; late in a run, with the relaxation activation, decoding costs as much as four episodes.

A memo keeps only the entries the last generation used, so its size stays that of one generation.
"""
from __future__ import annotations

from collections.abc import Hashable
from typing import Generic, TypeVar

from ..neat.genome import Genome

V = TypeVar("V")


def genome_key(genome: Genome) -> Hashable:
    """Everything decoding reads from a genome: its node and module genes and its connection genes in order."""
    return (genome.nodes, genome.modules, genome.innov.tobytes(), genome.src.tobytes(), genome.dst.tobytes(),
            genome.weight.tobytes())


class GenerationMemo(Generic[V]):
    """Key -> value for the keys of the current generation, remembering the previous generation's values.

    `get` looks a key up in both; `put` records a value for the current generation; `next_generation` forgets
    every key the generation now ending did not use.
    """

    def __init__(self) -> None:
        self._previous: dict[Hashable, V] = {}
        self._current: dict[Hashable, V] = {}

    def get(self, key: Hashable) -> V | None:
        value = self._current.get(key)
        if value is None:
            value = self._previous.get(key)
            if value is not None:
                self._current[key] = value
        return value

    def put(self, key: Hashable, value: V) -> None:
        self._current[key] = value

    def next_generation(self) -> None:
        self._previous, self._current = self._current, {}

    def __len__(self) -> int:
        return len(self._previous.keys() | self._current.keys())
