"""Options added for NEAT 2002 (Stanley & Miikkulainen) on XOR: off by default, bit-compatible when off."""

from __future__ import annotations

import json

import numpy as np
import pytest

from mahn_evo.neat import Genome, NeatSettings, Population, compatibility_distance
from mahn_evo.neat.reproduction import top_two_targets
from mahn_evo.neat.speciation import RepresentativeIndex
from mahn_evo.neat.xor import evaluate_xor, xor_settings, xor_settings_neat2002
from tests.evo.helpers import random_genome

NODES = [(0, "bias", "null"), (1, "input", "null"), (2, "input", "null"), (3, "output", "sigmoid")]


def _g(weights):
    return Genome(NODES, [4, 5, 6], [0, 1, 2], [3, 3, 3], weights)


def test_later_fields_round_trip_and_an_absent_one_means_its_default():
    """Version-1 files left these settings out at their default (mahn_evo.storage.migrate): absent means default."""
    later = {"crossover_mutation_probability", "population_stagnation_generations", "weight_difference_mean",
             "species_order", "stagnation_rule"}
    d = NeatSettings().to_dict()
    assert NeatSettings.from_mapping({k: v for k, v in d.items() if k not in later}) == NeatSettings()
    s = NeatSettings(crossover_mutation_probability=0.8, population_stagnation_generations=20,
                     weight_difference_mean=True, species_order="random", stagnation_rule="sticky")
    back = NeatSettings.from_mapping(json.loads(json.dumps(s.to_dict())))
    assert back == s and later <= set(s.to_dict())
    with pytest.raises(ValueError, match="crossover_mutation_probability"):
        NeatSettings(crossover_mutation_probability=1.5)
    with pytest.raises(ValueError, match="population_stagnation_generations"):
        NeatSettings(population_stagnation_generations=-1)


def test_weight_difference_mean():
    s = NeatSettings(weight_coefficient=0.4, weight_difference_mean=True)
    a, b = _g([1.0, 1.0, 1.0]), _g([0.0, 0.0, -2.0])
    assert compatibility_distance(a, b, s) == pytest.approx(0.4 * (1 + 1 + 3) / 3)
    assert compatibility_distance(a, b, s.replace(weight_difference_mean=False)) == pytest.approx(0.4 * 5)
    genomes = [random_genome(k, steps=3 * k) for k in range(6)]
    index = RepresentativeIndex(genomes, s)
    for r in genomes[:3]:
        index.add(r)
    for g in genomes:
        want = [compatibility_distance(g, r, s) for r in genomes[:3]]
        assert index.distances(g) == pytest.approx(want)


def test_top_two_targets():
    assert top_two_targets(np.array([5.0]), 0, 150).tolist() == [150]
    t = top_two_targets(np.array([1.0, 9.0, 3.0, 3.0]), 1, 151)
    assert t.tolist() == [0, 76, 75, 0]  # champion gets the odd one; ties go to the earlier species
    # the champion species is kept even if another species' top is recorded higher (ties in the champion search)
    assert top_two_targets(np.array([9.0, 9.0, 1.0]), 1, 10).tolist() == [5, 5, 0]


def test_population_stagnation_refocuses_on_two_species():
    s = xor_settings(60, population_stagnation_generations=3, species_count_min=4, species_count_max=6)
    pop = Population.create(s, seed=4, kind="minimal", n_inputs=2, n_outputs=1, output_activation="sigmoid")
    flat = np.ones(60)
    counts = []
    for _ in range(6):
        n_before = len(pop.species)
        pop.tell(flat)  # never improves after generation 0
        counts.append((n_before, pop.last_improvement))
    # generation 4 is the first with gen - last_improvement > 3: the counter restarts there
    assert [li for _, li in counts] == [0, 0, 0, 0, 4, 4]


def test_crossover_mutation_changes_offspring_but_stays_deterministic():
    base = xor_settings(60)
    on = base.replace(crossover_mutation_probability=1.0, asexual_proportion=0.0)
    runs = []
    for s in (base.replace(asexual_proportion=0.0), on, on):
        pop = Population.create(s, seed=7, kind="minimal", n_inputs=2, n_outputs=1, output_activation="sigmoid")
        for _ in range(5):
            pop.tell(evaluate_xor(pop.ask())[0])
        runs.append(pop)
    assert runs[1].genomes == runs[2].genomes
    assert runs[0].genomes != runs[1].genomes
    for g in runs[1].genomes:
        g.validate()


def test_neat2002_preset_resumes_bit_identically():
    s = xor_settings_neat2002(50)
    a = Population.create(s, seed=11, kind="minimal", n_inputs=2, n_outputs=1, output_activation="sigmoid")
    for _ in range(4):
        a.tell(evaluate_xor(a.ask())[0])
    b = Population.from_dict(json.loads(json.dumps(a.to_dict())))
    for _ in range(4):
        a.tell(evaluate_xor(a.ask())[0])
        b.tell(evaluate_xor(b.ask())[0])
    assert a.genomes == b.genomes and a.last_improvement == b.last_improvement
    assert [sp.members for sp in a.species] == [sp.members for sp in b.species]
