"""Shared helpers for the NEAT / CPPN tests (imported as a plain module: tests/evo is on sys.path)."""

from __future__ import annotations

import numpy as np

from mahn_evo.neat import Genome, InnovationTracker, NeatSettings, initial_population, mutate

#: Settings that grow structure quickly (random genomes with hidden nodes and recurrent links).
STRUCTURAL = NeatSettings(
    population_size=20,
    mutate_weights_probability=0.3,
    add_connection_probability=0.4,
    add_node_probability=0.3,
    hidden_activations=("bipolar_sigmoid", "gaussian", "abs", "sine", "sigmoid"),
)


def grow(genome: Genome, steps: int, rng: np.random.Generator, tracker: InnovationTracker,
         settings: NeatSettings = STRUCTURAL) -> Genome:
    """Apply ``steps`` single mutations (a new innovation generation every 3 steps)."""
    for k in range(steps):
        if k % 3 == 0:
            tracker.new_generation()
        genome = mutate(genome, rng, settings, tracker)
    return genome


def random_genome(seed: int, steps: int = 30, kind: str = "minimal", n_inputs: int = 4) -> Genome:
    """A genome grown from an initial one by random structural mutations (recurrent links included)."""
    rng = np.random.Generator(np.random.PCG64(seed))
    if kind == "iros2011":
        n_inputs = 6
    genomes, tracker = initial_population(kind, n_inputs, STRUCTURAL, rng)
    return grow(genomes[int(rng.integers(len(genomes)))], steps, rng, tracker)
