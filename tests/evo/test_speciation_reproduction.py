"""Compatibility distance (hand-computed), threshold dynamics, apportionment and elitism."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from mahn_evo.neat import Genome, NeatSettings, Species, ThresholdController, compatibility_distance
from mahn_evo.neat.reproduction import apportion, elite_sizes, target_sizes
from mahn_evo.neat.speciation import RepresentativeIndex, speciate_all
from tests.evo.helpers import random_genome

NODES = [(0, "bias", "null"), (1, "input", "null"), (2, "input", "null"), (3, "output", "sigmoid"),
         (10, "hidden", "sigmoid"), (11, "hidden", "sigmoid")]


def _g(conns):
    """conns: list of (innovation, weight); endpoints are made unique per innovation."""
    pairs = {4: (0, 3), 5: (1, 3), 6: (2, 3), 7: (1, 10), 8: (10, 3), 9: (2, 11), 12: (11, 3), 13: (0, 10),
             14: (0, 11)}
    return Genome(NODES, [i for i, _ in conns], [pairs[i][0] for i, _ in conns], [pairs[i][1] for i, _ in conns],
                  [w for _, w in conns])


def test_distance_hand_computed():
    s = NeatSettings()
    a = _g([(4, 1.0), (5, -0.5), (6, 0.25), (7, 1.0), (8, 0.5)])
    b = _g([(4, 0.0), (5, 0.5), (6, 0.25), (9, 1.0), (12, 0.3), (13, 0.2), (14, 0.1)])
    # matching 4, 5, 6: sum|dw| = 1 + 1 + 0 = 2 -> 0.05 * 2 = 0.1
    # a's 7, 8 are below b's max (14) -> disjoint; b's 9, 12 are below a's max (8)? 9 > 8 -> excess; all of
    # b's 9, 12, 13, 14 exceed 8 -> excess 4; disjoint 2
    assert compatibility_distance(a, b, s) == pytest.approx(2 + 4 + 0.1)
    s2 = NeatSettings(disjoint_coefficient=2.0, excess_coefficient=0.5, weight_coefficient=1.0)
    assert compatibility_distance(a, b, s2) == pytest.approx(2 * 2 + 0.5 * 4 + 2.0)
    assert compatibility_distance(b, a, s2) == pytest.approx(2 * 2 + 0.5 * 4 + 2.0)
    assert compatibility_distance(a, a, s) == 0.0
    # weights are summed, not averaged: 10 matching genes each differing by 1 give 0.05 * 10
    empty = Genome(NODES, [], [], [], [])
    assert compatibility_distance(a, empty, s2) == pytest.approx(0.5 * 5)  # all excess


def test_distance_sum_not_mean():
    s = NeatSettings()
    a = _g([(4, 1.0), (5, 1.0), (6, 1.0)])
    b = _g([(4, 0.0), (5, 0.0), (6, 0.0)])
    assert compatibility_distance(a, b, s) == pytest.approx(0.05 * 3)


@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 5000), coeffs=st.sampled_from([(1.0, 1.0, 0.05), (2.0, 0.5, 0.4), (0.0, 3.0, 1.0)]))
def test_representative_index_matches_scalar_distance(seed, coeffs):
    s = NeatSettings(disjoint_coefficient=coeffs[0], excess_coefficient=coeffs[1], weight_coefficient=coeffs[2])
    genomes = [random_genome(seed * 7 + k, steps=k * 3) for k in range(8)]
    # random_genome lineages differ, so innovation ids overlap only on the initial genes: good mixed cases
    index = RepresentativeIndex(genomes, s)
    for r in genomes[:4]:
        index.add(r)
    for g in genomes:
        d = index.distances(g)
        want = [compatibility_distance(g, r, s) for r in genomes[:4]]
        np.testing.assert_allclose(d, want, rtol=1e-12, atol=1e-12)


def test_speciate_all_first_compatible_and_identity_inheritance():
    s = NeatSettings(population_size=10)
    a = _g([(4, 1.0), (5, 1.0), (6, 1.0)])
    b = _g([(4, 1.0), (5, 1.0), (6, 1.0), (7, 0.1), (8, 0.1), (13, 0.1), (9, 0.1)])  # distance 4 from a
    genomes = [a, b, a.with_weights(np.array([1.0, 1.0, 0.0])), b]
    species, next_id = speciate_all(genomes, 3.0, s, (), generation=0, next_species_id=0)
    assert [sp.members for sp in species] == [[0, 2], [1, 3]]
    assert [sp.id for sp in species] == [0, 1] and next_id == 2
    # re-speciation: the new species founded by genome 1 takes over old species 7's identity
    old = [Species(7, [1, 3], created=2, best_fitness=5.0, last_improvement=4), Species(9, [0, 2], 1, 3.0, 3)]
    species, next_id = speciate_all(genomes, 3.0, s, old, generation=10, next_species_id=20)
    assert [(sp.id, sp.members, sp.best_fitness) for sp in species] == [(7, [1, 3], 5.0), (9, [0, 2], 3.0)]
    assert next_id == 20
    # a threshold of 4 (strict <) still separates them; 4.01 merges
    assert len(speciate_all(genomes, 4.0, s, (), 0, 0)[0]) == 2
    assert len(speciate_all(genomes, 4.01, s, (), 0, 0)[0]) == 1


def test_threshold_dynamics():
    s = NeatSettings()  # target 48..50
    t = ThresholdController(8.0)
    assert t.adjust(1, s) and t.threshold == pytest.approx(7.9) and t.delta == pytest.approx(-0.1)
    assert t.adjust(1, s) and t.delta == pytest.approx(-0.105) and t.threshold == pytest.approx(7.795)
    assert t.adjust(60, s) and t.delta == pytest.approx(0.0525)  # overshoot: * -0.5
    assert t.adjust(60, s) and t.delta == pytest.approx(0.0525 * 1.05)
    assert not t.adjust(49, s) and t.delta == 0.0
    thr = t.threshold
    assert t.adjust(100, s) and t.delta == pytest.approx(max(0.1, 0.01 * thr))
    big = ThresholdController(50.0)
    big.adjust(0, s)
    assert big.delta == pytest.approx(-0.5)  # 1 % of the threshold when that exceeds 0.1
    low = ThresholdController(0.05)
    low.adjust(0, s)
    assert low.threshold == 0.01
    assert not low.adjust(0, s)  # floored: no change, no re-speciation


@settings(max_examples=200, deadline=None)
@given(shares=st.lists(st.floats(1e-7, 1e3), min_size=1, max_size=60), total=st.integers(1, 1000))
def test_apportion_sums_exactly(shares, total):
    t = apportion(np.array(shares), total)
    assert t.sum() == total and np.all(t >= 0)
    quotas = np.array(shares) / np.sum(shares) * total
    assert np.all(np.abs(t - quotas) < 1.0 + 1e-9)  # largest remainder: never more than 1 from the quota


@settings(max_examples=200, deadline=None)
@given(shares=st.lists(st.floats(1e-7, 1e3), min_size=1, max_size=60), total=st.integers(1, 600),
       data=st.data())
def test_targets_and_elites(shares, total, data):
    champ = data.draw(st.integers(0, len(shares) - 1))
    t = target_sizes(np.array(shares), champ, total)
    assert t.sum() == total and t[champ] >= 1
    sizes = np.array(data.draw(st.lists(st.integers(1, 50), min_size=len(shares), max_size=len(shares))))
    e = elite_sizes(t, sizes, champ, 0.2)
    assert np.all(e <= t) and np.all(e <= np.maximum(sizes, 1)) and e[champ] >= 1
    assert np.all(e[(t > 1)] >= 1)


def test_apportion_ties_go_to_earlier_species():
    assert apportion(np.array([1.0, 1.0, 1.0]), 4).tolist() == [2, 1, 1]
    assert apportion(np.array([1.0, 1.0, 1.0]), 5).tolist() == [2, 2, 1]


def test_speciate_all_tries_the_parents_species_first():
    s = NeatSettings(population_size=10)
    a = _g([(4, 1.0), (5, 1.0), (6, 1.0)])
    b = _g([(4, 1.0), (5, 1.0), (6, 1.0), (7, 0.1), (8, 0.1), (13, 0.1), (9, 0.1)])  # distance 4 from a
    c = _g([(4, 1.0), (5, 1.0), (6, 1.0), (7, 0.1), (8, 0.1)])  # distance 2 from both
    old = [Species(7, [0], 0, 1.0, 0), Species(9, [1], 0, 1.0, 0)]
    plain, _ = speciate_all([a, b, c], 3.0, s, old, 5, 20)
    assert [(sp.id, sp.members) for sp in plain] == [(7, [0, 2]), (9, [1])]  # first compatible in order
    parents = [(), (), (9,)]
    pref, _ = speciate_all([a, b, c], 3.0, s, old, 5, 20, parents)
    assert [(sp.id, sp.members) for sp in pref] == [(7, [0]), (9, [1, 2])]
    # a parent species that is not formed (yet) or not compatible is skipped
    old = [Species(7, [0], 0, 1.0, 0), Species(9, [2], 0, 1.0, 0)]
    early, _ = speciate_all([a, c, b], 3.0, s, old, 5, 20, [(), (9,), ()])
    assert [(sp.id, sp.members) for sp in early] == [(7, [0, 1]), (9, [2])]
