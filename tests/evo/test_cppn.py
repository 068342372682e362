"""The compiled CPPN evaluator against a literal recursive implementation of the original's activation."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from mahn_evo.cppn import activations as A
from mahn_evo.cppn import compile_cppn
from mahn_evo.neat import Genome, NeatSettings, initial_population, iros2011_seed_genome
from tests.evo.helpers import random_genome


# ----------------------------------------------------------------------------------------------------------------
# Reference: the original's recursive activation (docs/original-system.md section 6), one query at a time,
# written independently of the plan compiler.
def _act(name: str, x, dtype):
    return A.ACTIVATIONS[name][1](np.array([x], dtype=dtype))[0]


def reference_activate(genome: Genome, query, evaluate_modules: bool = False, dtype=np.float32) -> list:
    t = np.dtype(dtype).type
    kind = {n.id: n.kind for n in genome.nodes}
    actf = {n.id: n.activation for n in genome.nodes}
    conns = list(zip(genome.src.tolist(), genome.dst.tolist(), genome.weight.tolist()))
    module_inputs = {o: m.inputs for m in genome.modules for o in m.outputs}
    value = {nid: t(0) for nid in kind}  # 1. clear every signal ...
    done, in_progress = set(), set()
    for nid, k in kind.items():
        if k == "bias":
            value[nid] = t(1)  # ... except the bias
            done.add(nid)
    for j, nid in enumerate(genome.input_ids):  # 2. write the inputs
        value[nid] = t(query[j])
        done.add(nid)
    saved = dict(value)  # signals at the start of the query (0 for every non-bias, non-input node)

    def evaluate(nid):
        in_progress.add(nid)
        if kind[nid] == "module_out":
            if evaluate_modules:
                prod = t(1)
                for i in module_inputs[nid]:
                    if i in in_progress:
                        prod = prod * saved[i]
                    else:
                        if i not in done:
                            evaluate(i)
                        prod = prod * value[i]
                value[nid] = prod
            else:
                value[nid] = t(0)
        else:
            total = t(0)
            for s, d, w in conns:  # genome connection-list order
                if d != nid:
                    continue
                if s in in_progress:
                    total = total + t(w) * saved[s]
                else:
                    if s not in done:
                        evaluate(s)
                    total = total + t(w) * value[s]
            value[nid] = _act(actf[nid], total, dtype)
        in_progress.discard(nid)
        done.add(nid)

    out = []
    for o in genome.output_ids:  # 3. output 0, then output 1, ...
        if o not in done:
            evaluate(o)
        out.append(value[o])
    return out


def _reference_matrix(genome, x, evaluate_modules=False, dtype=np.float32):
    return np.array([reference_activate(genome, q, evaluate_modules, dtype) for q in x], dtype=np.float64)


# ----------------------------------------------------------------------------------------------------------------
def test_activation_functions_match_the_sheet():
    x = np.array([-1.0, -0.3, 0.0, 0.2, 1.5], dtype=np.float64)
    np.testing.assert_allclose(A.bipolar_sigmoid(x), 2 / (1 + np.exp(-4.9 * x)) - 1)
    np.testing.assert_allclose(A.gaussian(x), 2 * np.exp(-((2.5 * x) ** 2)) - 1)
    np.testing.assert_allclose(A.absolute(x), np.abs(x))
    np.testing.assert_allclose(A.sine(x), np.sin(2 * x))
    np.testing.assert_allclose(A.sigmoid(x), 1 / (1 + np.exp(-4.9 * x)))
    e = A.error_sign(np.array([-1e-3, -1e-4, -5e-5, 0.0, 5e-5, 1e-4, 2.0]))
    np.testing.assert_array_equal(e, [-1, -1, 0, 0, 0, 1, 1])
    assert A.bipolar_sigmoid(np.float32([0.3])).dtype == np.float32
    assert A.bipolar_sigmoid(np.float32([-200.0]))[0] == -1.0  # no overflow trouble


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 10_000), steps=st.integers(0, 60), kind=st.sampled_from(["minimal", "iros2011"]),
       modules=st.booleans())
def test_plan_matches_recursive_reference(seed, steps, kind, modules):
    g = random_genome(seed, steps, kind)
    g.validate()
    rng = np.random.default_rng(seed)
    x = rng.uniform(-1, 1, size=(7, len(g.input_ids)))
    plan = compile_cppn(g, evaluate_modules=modules)
    got32 = plan.evaluate(x)
    assert got32.dtype == np.float32 and got32.shape == (7, len(g.output_ids))
    np.testing.assert_allclose(got32, _reference_matrix(g, x, modules, np.float32), rtol=0, atol=1e-6)
    got64 = plan.evaluate(x, dtype=np.float64)
    np.testing.assert_allclose(got64, _reference_matrix(g, x, modules, np.float64), rtol=0, atol=1e-12)


def test_random_genomes_have_recurrent_links():
    """The property test above is only meaningful if it meets cycles and self-loops."""
    found = 0
    for seed in range(30):
        g = random_genome(seed, 40)
        if any(s == d for s, d in zip(g.src.tolist(), g.dst.tolist())) or _has_cycle(g):
            found += 1
    assert found >= 10


def _has_cycle(g: Genome) -> bool:
    succ = {}
    for s, d in zip(g.src.tolist(), g.dst.tolist()):
        succ.setdefault(s, []).append(d)
    color = {}

    def dfs(v):
        color[v] = 1
        for w in succ.get(v, ()):
            if color.get(w) == 1 or (w not in color and dfs(w)):
                return True
        color[v] = 2
        return False

    return any(v not in color and dfs(v) for v in list(succ))


def test_back_edge_contributes_zero_and_order_matters():
    """out <- h (w=1), h <- out (w=1), h <- bias (w=0.5): h sees out 'in progress' -> 0."""
    nodes = [(0, "bias", "null"), (1, "input", "null"), (2, "output", "abs"), (5, "hidden", "abs")]
    g = Genome(nodes, [3, 4, 6], [5, 2, 0], [2, 5, 5], [1.0, 1.0, 0.5])
    g.validate()
    y = compile_cppn(g).evaluate(np.zeros((1, 1)))
    assert y[0, 0] == pytest.approx(0.5)
    # a self-loop is in progress too
    g2 = Genome(nodes[:3], [3, 4], [2, 0], [2, 2], [10.0, -0.25])
    assert compile_cppn(g2).evaluate(np.zeros((1, 1)))[0, 0] == pytest.approx(0.25)


def test_nodes_done_for_output_0_are_reused_for_output_1():
    """With output 1 -> output 0, output 1 is evaluated inside output 0's DFS and reused, not recomputed."""
    nodes = [(0, "bias", "null"), (1, "input", "null"), (2, "output", "identity"), (3, "output", "identity")]
    g = Genome(nodes, [4, 5, 6], [3, 1, 2], [2, 3, 3], [1.0, 1.0, 1.0])  # o0 <- o1; o1 <- x; o1 <- o0 (back edge)
    y = compile_cppn(g).evaluate(np.array([[0.75]]))
    np.testing.assert_allclose(y, [[0.75, 0.75]])


# ----------------------------------------------------------------------------------------------------------------
def _seed_population(n_inputs, n=6):
    rng = np.random.Generator(np.random.PCG64(7))
    genomes, _ = initial_population("iros2011", n_inputs, NeatSettings(population_size=n), rng)
    return genomes


@pytest.mark.parametrize("n_inputs", [6, 5])
def test_seed_genome_effective_behaviour(n_inputs):
    """x1, x2 and z are inert (the Multiply modules output 0); outputs depend on bias, y1, y2 (and S) only."""
    genomes = _seed_population(n_inputs)
    rng = np.random.default_rng(0)
    q = rng.uniform(-1, 1, size=(200, n_inputs))
    out0 = compile_cppn(genomes[0]).evaluate(q)
    np.testing.assert_array_equal(out0, 0.0)  # genome 0: every weight into the outputs is 0
    for g in genomes[1:]:
        plan = compile_cppn(g)
        base = plan.evaluate(q)
        for col in (0, 2, 4):  # x1, x2, z
            q2 = q.copy()
            q2[:, col] = rng.uniform(-1, 1, size=len(q))
            np.testing.assert_array_equal(plan.evaluate(q2), base)
        live = [1, 3] + ([5] if n_inputs == 6 else [])  # y1, y2, S
        for col in live:
            q2 = q.copy()
            q2[:, col] += 0.5
            assert np.any(plan.evaluate(q2) != base)


def test_seed_modules_live_when_evaluated():
    """With evaluate_modules=True the products sign(z)*x1 and sign(z)*x2 reach the outputs (jittered genomes)."""
    g = _seed_population(6)[1]
    plan = compile_cppn(g, evaluate_modules=True)
    rng = np.random.default_rng(1)
    q = rng.uniform(-1, 1, size=(50, 6))
    q[:, 4] = 1.0  # z = +1 so sign(z) = 1
    base = plan.evaluate(q)
    for col in (0, 2):
        q2 = q.copy()
        q2[:, col] += 0.5
        assert np.all(np.abs(plan.evaluate(q2) - base) > 0)
    q0 = q.copy()
    q0[:, 4] = 0.0  # sign(0) = 0: the modules output 0 again, x1 inert
    b0 = plan.evaluate(q0)
    q1 = q0.copy()
    q1[:, 0] += 0.5
    np.testing.assert_array_equal(plan.evaluate(q1), b0)
    # genome 0 (exact seed): x1 -> module input has weight 0, so x1 stays inert even with modules evaluated
    p0 = compile_cppn(iros2011_seed_genome(6), evaluate_modules=True)
    np.testing.assert_array_equal(p0.evaluate(q), p0.evaluate(q + np.array([0.3, 0, 0.3, 0, 0, 0])))


def test_plan_shape_errors():
    plan = compile_cppn(iros2011_seed_genome(6))
    with pytest.raises(ValueError, match="shape"):
        plan.evaluate(np.zeros((3, 5)))
    assert plan.evaluate(np.zeros(6)).shape == (1, 2)
