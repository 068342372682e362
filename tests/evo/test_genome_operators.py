"""Genomes, the seed genomes, and property tests that every operator keeps genomes valid."""

from __future__ import annotations

import json

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from mahn_evo.neat import (
    Genome,
    InnovationTracker,
    NeatSettings,
    add_connection,
    add_node,
    crossover,
    initial_population,
    iros2011_seed_genome,
    mutate,
    mutate_weights,
)
from tests.evo.helpers import STRUCTURAL, grow


def _check(g: Genome, limit: float | None) -> None:
    g.validate(weight_limit=limit)
    assert np.all(np.diff(g.innov) > 0)  # unique and sorted
    pairs = list(zip(g.src.tolist(), g.dst.tolist()))
    assert len(set(pairs)) == len(pairs)
    ids = {n.id for n in g.nodes}
    assert all(s in ids and d in ids for s, d in pairs)


# ----------------------------------------------------------------------------------------------------------------
def test_seed_genome_switch_structure():
    g = iros2011_seed_genome(6)
    assert [n.id for n in g.nodes] == [0, 1, 2, 3, 4, 5, 6, 7, 8, 350, 352, 354, 356, 358, 360, 609]
    assert g.innov.tolist() == list(range(9, 26))
    assert g.output_ids == (7, 8) and g.input_ids == (1, 2, 3, 4, 5, 6)
    w = dict(zip(zip(g.src.tolist(), g.dst.tolist()), g.weight.tolist()))
    assert w[(5, 609)] == 1.0 and w[(609, 350)] == 1.0 and w[(609, 356)] == 1.0
    assert w[(1, 352)] == 0.0 and w[(3, 358)] == 0.0
    for s in (0, 2, 4, 6, 354, 360):
        assert w[(s, 7)] == 0.0 and w[(s, 8)] == 0.0
    assert g._info.sources.size == 12  # add-connection candidates, as in docs/original-system.md section 8
    assert sorted(g._info.targets.tolist()) == [7, 8, 609]


def test_seed_genome_signal_structure():
    g = iros2011_seed_genome(5)
    assert g.innov.tolist() == list(range(8, 23))
    assert g.output_ids == (6, 7)


def test_iros2011_population():
    s = NeatSettings(population_size=50)
    genomes, tracker = initial_population("iros2011", 6, s, np.random.Generator(np.random.PCG64(3)))
    assert tracker.next_id == 610
    assert genomes[0] == iros2011_seed_genome(6)
    seed_w = genomes[0].weight
    for g in genomes[1:]:
        d = g.weight - seed_w
        assert np.all(np.abs(d) <= 0.1) and np.all(d != 0)
        assert np.array_equal(g.innov, genomes[0].innov)


def test_minimal_population():
    s = NeatSettings(population_size=10)
    genomes, tracker = initial_population("minimal", 3, s, np.random.Generator(np.random.PCG64(3)), n_outputs=2)
    g = genomes[0]
    assert g.n_connections == 8 and g.n_hidden == 0
    assert tracker.next_id == 1 + 3 + 2 + 8
    for h in genomes:
        _check(h, 1.5)
        assert np.array_equal(h.innov, g.innov)
    with pytest.raises(ValueError, match="kind"):
        initial_population("random", 3, s, np.random.default_rng(0))


def test_json_round_trip():
    rng = np.random.Generator(np.random.PCG64(5))
    genomes, tracker = initial_population("iros2011", 6, STRUCTURAL, rng)
    g = grow(genomes[3], 25, rng, tracker)
    back = Genome.from_dict(json.loads(json.dumps(g.to_dict())))
    assert back == g


@pytest.mark.parametrize(
    "mutate_dict, message",
    [
        (lambda d: d["connections"].append(list(d["connections"][0])), "innovations"),
        (lambda d: d["connections"].append([999, *d["connections"][0][1:3], 0.5]), "duplicate connection endpoints"),
        (lambda d: d["connections"].append([999, 0, 77, 0.5]), "target 77 is not a node"),
        (lambda d: d["connections"].append([999, 0, 1, 0.5]), "ends at input node"),
        (lambda d: d["nodes"].append([5, "hidden", "gaussian"]), "duplicate node id"),
        (lambda d: d["nodes"].append([900, "hidden", "tanh"]), "unknown activation"),
        (lambda d: d["modules"].pop(), "belongs to no module"),
        (lambda d: d.pop("nodes"), "missing field 'nodes'"),
    ],
)
def test_validate_names_the_inconsistency(mutate_dict, message):
    d = iros2011_seed_genome(6).to_dict()
    mutate_dict(d)
    with pytest.raises(ValueError, match=message):
        Genome.from_dict(d)


def test_validate_weight_bounds():
    g = iros2011_seed_genome(6)
    g2 = g.with_weights(np.where(np.arange(g.n_connections) == 3, 2.0, g.weight))
    g2.validate()
    with pytest.raises(ValueError, match="outside"):
        g2.validate(weight_limit=1.5)


def test_arrays_are_read_only():
    g = iros2011_seed_genome(6)
    with pytest.raises(ValueError):
        g.weight[0] = 3.0


# ----------------------------------------------------------------------------------------------------------------
@settings(max_examples=60, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), kind=st.sampled_from(["minimal", "iros2011"]),
       ops=st.lists(st.sampled_from(["mutate", "weights", "node", "conn", "cross", "newgen"]), max_size=40),
       recurrent=st.booleans())
def test_operators_keep_genomes_valid(seed, kind, ops, recurrent):
    s = STRUCTURAL.replace(allow_recurrent=recurrent, add_node_keeps_split_connection=bool(seed % 2))
    rng = np.random.Generator(np.random.PCG64(seed))
    genomes, tracker = initial_population(kind, 6 if kind == "iros2011" else 3, s, rng)
    lim = s.weight_limit + s.initial_weight_jitter  # initial jitter is unclamped (original)
    pool = list(genomes[:6])
    for op in ops:
        i, j = int(rng.integers(len(pool))), int(rng.integers(len(pool)))
        g = pool[i]
        if op == "mutate":
            child = mutate(g, rng, s, tracker)
        elif op == "weights":
            child = mutate_weights(g, rng, s)
            assert child.n_connections == g.n_connections
        elif op == "node":
            child = add_node(g, rng, s, tracker) or g
        elif op == "conn":
            child = add_connection(g, rng, s, tracker) or g
        elif op == "cross":
            child = crossover(g, float(rng.random()), pool[j], float(rng.random()), rng, s)
        else:
            tracker.new_generation()
            continue
        _check(child, lim)
        if not recurrent and op != "cross":
            from tests.evo.test_cppn import _has_cycle

            if not _has_cycle(g):
                assert not _has_cycle(child)
        pool.append(child)


def test_add_node_reuses_ids_within_a_generation():
    s = STRUCTURAL
    g = iros2011_seed_genome(6)
    tracker = InnovationTracker(610)
    # the same connection split in two genomes, same generation -> same ids; next generation -> new ids
    a = _split(g, 5, s, tracker, seed=1)
    b = _split(g, 5, s, tracker, seed=2)
    assert a == b
    tracker.new_generation()
    c = _split(g, 5, s, tracker, seed=1)
    assert set(c.innov.tolist()) - set(g.innov.tolist()) != set(a.innov.tolist()) - set(g.innov.tolist())


def _split(g, k, s, tracker, seed):
    class FixedRng:
        """Chooses connection k, then delegates to a real generator."""

        def __init__(self):
            self.r = np.random.default_rng(seed)
            self.first = True

        def integers(self, n):
            if self.first:
                self.first = False
                return k
            return self.r.integers(n)

    child = add_node(g, FixedRng(), s, tracker)
    # the split connection is kept (original), so the child has two more connections
    assert child.n_connections == g.n_connections + 2 and child.n_hidden == g.n_hidden + 1
    return child


def test_add_connection_reuses_ids_within_a_generation():
    s = STRUCTURAL.replace(add_connection_attempts=50)
    g = iros2011_seed_genome(6)
    tracker = InnovationTracker(610)
    seen: dict[tuple[int, int], int] = {}
    for seed in range(40):
        child = add_connection(g, np.random.Generator(np.random.PCG64(seed)), s, tracker)
        new = np.flatnonzero(~np.isin(child.innov, g.innov))
        assert new.size == 1
        key = (int(child.src[new[0]]), int(child.dst[new[0]])), int(child.innov[new[0]])
        assert seen.setdefault(key[0], key[1]) == key[1]
        assert abs(child.weight[new[0]]) <= s.new_connection_weight_range
    assert len(seen) > 5


def test_weight_mutation_changes_something_and_clamps():
    s = STRUCTURAL
    rng = np.random.Generator(np.random.PCG64(0))
    g = iros2011_seed_genome(6)
    edge = g.with_weights(np.full(17, 1.5))
    for _ in range(200):
        c = mutate_weights(g, rng, s)
        assert np.any(c.weight != g.weight)  # the proportional schemes fall back to one connection
        assert np.all(np.abs(mutate_weights(edge, rng, s).weight) <= 1.5)  # jiggles are clamped
        assert np.array_equal(c.innov, g.innov)


def test_crossover_rules():
    s = STRUCTURAL.replace(disjoint_excess_recombine_probability=0.0)
    rng = np.random.Generator(np.random.PCG64(9))
    genomes, tracker = initial_population("iros2011", 6, s, rng)
    a = grow(genomes[1], 10, rng, tracker)
    b = grow(genomes[2], 10, rng, tracker)
    child = crossover(a, 2.0, b, 1.0, rng, s)
    assert np.array_equal(child.innov, a.innov)  # structure of the fitter parent only
    common = np.intersect1d(a.innov, b.innov)
    wa = dict(zip(a.innov.tolist(), a.weight.tolist()))
    wb = dict(zip(b.innov.tolist(), b.weight.tolist()))
    for i, w in zip(child.innov.tolist(), child.weight.tolist()):
        assert w in ((wa[i], wb[i]) if i in common else (wa[i],))
    s1 = s.replace(disjoint_excess_recombine_probability=1.0)
    both = crossover(a, 2.0, b, 1.0, rng, s1)
    _check(both, None)
    assert set(both.innov.tolist()) >= set(a.innov.tolist())
    assert both.n_connections >= a.n_connections
