"""Deterministic NEAT (SharpNEAT 1.0 / HyperSharpNEAT rules) in numpy: genomes, operators, speciation, population.

Quick start (ask/tell)::

    from mahn_evo.neat import NeatSettings, Population
    pop = Population.create(NeatSettings(), seed=1, kind="iros2011", n_inputs=6)
    stats = pop.tell(my_batch_evaluator(pop.ask()))
    state = pop.to_dict()                  # JSON-able; Population.from_dict(state) resumes bit-identically
"""

from .crossover import crossover
from .genome import NODE_KINDS, Genome, ModuleGene, NodeGene
from .initial import initial_population, iros2011_seed_genome, minimal_genome
from .innovation import InnovationTracker
from .mutation import add_connection, add_node, mutate, mutate_weights
from .population import GenerationStats, Population
from .settings import (
    CppnSettings,
    InitialisationSettings,
    MutationSettings,
    NeatSettings,
    ReproductionSettings,
    SelectionSettings,
    SpeciationSettings,
)
from .speciation import Species, ThresholdController, compatibility_distance

__all__ = [
    "NODE_KINDS",
    "Genome",
    "NodeGene",
    "ModuleGene",
    "InnovationTracker",
    "NeatSettings",
    "ReproductionSettings",
    "SelectionSettings",
    "MutationSettings",
    "SpeciationSettings",
    "InitialisationSettings",
    "CppnSettings",
    "initial_population",
    "iros2011_seed_genome",
    "minimal_genome",
    "mutate",
    "mutate_weights",
    "add_node",
    "add_connection",
    "crossover",
    "compatibility_distance",
    "Species",
    "ThresholdController",
    "Population",
    "GenerationStats",
]
