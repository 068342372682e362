"""The original code's behaviour as named options: relaxation activation, random species order, sticky stagnation,
and the presets that combine them."""
from __future__ import annotations

import json

import numpy as np
import pytest

from mahn_evo.cppn import compile_cppn, compile_genome, compile_relax
from mahn_evo.cppn.relax import relax_steps
from mahn_evo.neat import Genome, NeatSettings, Population
from mahn_evo.neat.initial import iros2011_seed_genome
from mahn_evo.neat.speciation import Species, first_compatible, order_keys
from mahn_evo.training.config import EvolutionConfig
from mahn_evo.training.presets import PRESETS, apply_preset
from tests.evo.helpers import random_genome


def _queries(n_inputs: int, n: int = 64, seed: int = 0) -> np.ndarray:
    return np.random.default_rng(seed).uniform(-1, 1, (n, n_inputs)).astype(np.float32)


# ------------------------------------------------------------------ relaxation (MultipleSteps)
def test_relax_step_count_is_the_originals():
    g = iros2011_seed_genome(6)
    plan = compile_relax(g)
    # bias + 6 inputs + 2 outputs + node 609 + 2 x (2 module inputs + 1 module output) = 16 neurons
    assert len(g.nodes) == 16 and plan.steps == 2 * (16 - 8) + 1 == relax_steps(16, 6, 2)


def _live_seed() -> Genome:
    """The seed genome with its weights jittered, so x1, x2 reach the modules and every link carries a signal."""
    g = iros2011_seed_genome(6)
    w = np.asarray(g.weight).copy()
    w += np.random.default_rng(1).uniform(-0.5, 0.5, w.size)
    return Genome(g.nodes, g.innov, g.src, g.dst, w, g.modules)


def test_relax_of_an_acyclic_cppn_settles_on_the_recursive_pass_with_modules():
    """No cycles: after depth + 1 steps the signals are the feed-forward values (modules included)."""
    g = _live_seed()
    q = _queries(6)
    relaxed = compile_relax(g).evaluate(q)
    with_modules = compile_cppn(g, evaluate_modules=True).evaluate(q)
    without = compile_cppn(g, evaluate_modules=False).evaluate(q)
    np.testing.assert_allclose(relaxed, with_modules, atol=2e-6)
    assert np.max(np.abs(relaxed - without)) > 1e-3  # the modules matter here


def _with_self_loop(genome: Genome, node: int, weight: float) -> Genome:
    innov = np.append(genome.innov, genome.innov.max() + 1)
    return Genome(genome.nodes, innov, np.append(genome.src, node), np.append(genome.dst, node),
                  np.append(genome.weight, weight), genome.modules)


def test_relax_makes_recurrent_cppn_links_live_where_the_recursive_pass_ignores_them():
    g = _live_seed()
    out = g.output_ids[0]
    looped = _with_self_loop(g, out, 0.8)
    q = _queries(6)
    # recursive: a self-loop's source is "in progress", it adds 0
    np.testing.assert_array_equal(compile_cppn(looped).evaluate(q), compile_cppn(g).evaluate(q))
    # relaxation: it feeds the previous step's value
    assert np.max(np.abs(compile_relax(looped).evaluate(q) - compile_relax(g).evaluate(q))) > 1e-3


@pytest.mark.parametrize("seed", range(4))
def test_relax_is_deterministic_and_bounded_on_random_recurrent_cppns(seed):
    g = random_genome(seed, steps=40, kind="iros2011")
    q = _queries(6, seed=seed)
    a, b = compile_relax(g).evaluate(q), compile_genome(g, "relax").evaluate(q)
    np.testing.assert_array_equal(a, b)
    assert a.shape == (64, 2) and a.dtype == np.float32 and np.all(np.abs(a) <= 1.0)


@pytest.mark.parametrize("seed", range(6))
def test_relax_lanes_give_each_query_exactly_its_own_relaxation(seed):
    """Queries relax side by side in blocks (cppn/relax.py LANES); a block runs until its slowest lane settles.
    Each query must still get bit for bit what it gets alone, for block sizes that leave partial blocks."""
    from mahn_evo.cppn.relax import LANES
    g = random_genome(seed + 10, steps=60, kind="iros2011")
    plan = compile_relax(g)
    q = _queries(6, n=2 * LANES + 7, seed=seed)
    q[::5] = 0.0  # lanes that settle at different steps share blocks with the others
    together = plan.evaluate(q)
    alone = np.concatenate([plan.evaluate(q[i:i + 1]) for i in range(q.shape[0])])
    np.testing.assert_array_equal(together.view(np.uint32), alone.view(np.uint32))


def test_relax_needs_the_modules_evaluated():
    with pytest.raises(ValueError, match="relax.*evaluate_modules"):
        EvolutionConfig(cppn_activation="relax", evaluate_modules=False)
    with pytest.raises(ValueError, match="cppn_activation"):
        EvolutionConfig(cppn_activation="relaxed")


# ------------------------------------------------------------------ species order
def test_random_order_picks_the_compatible_species_with_the_smallest_key():
    d = np.array([5.0, 1.0, 9.0, 1.0, 1.0])
    keys = np.array([1, 50, 0, 7, 30], dtype=np.uint64)
    assert first_compatible(d, 3.0, ()) == 1  # by row (age)
    assert first_compatible(d, 3.0, (), keys) == 3  # by key among the compatible rows 1, 3, 4
    assert first_compatible(d, 3.0, (4,), keys) == 4  # parents' species still come first
    assert first_compatible(d, 0.5, (), keys) == -1


def test_order_keys_are_stable_per_id_and_depend_on_the_salt():
    a = order_keys([3, 1, 2], salt=11)
    assert np.array_equal(a, order_keys([3, 1, 2], salt=11))
    assert a[0] == order_keys([3], salt=11)[0]
    assert not np.array_equal(a, order_keys([3, 1, 2], salt=12))
    assert sorted(np.argsort(order_keys(np.arange(50), 5)).tolist()) == list(range(50))
    assert np.argsort(order_keys(np.arange(50), 5)).tolist() != list(range(50))  # not the age order


def _run(settings: NeatSettings, gens: int, seed: int = 2) -> Population:
    pop = Population.create(settings, seed=seed, kind="iros2011", n_inputs=6)
    rng = np.random.default_rng(seed)
    for _ in range(gens):
        pop.tell(rng.uniform(1, 5, settings.population_size))
    return pop


SMALL = NeatSettings(population_size=60, initial_compatibility_threshold=0.6, add_connection_probability=0.3,
                     add_node_probability=0.1)


def test_random_species_order_changes_placement_and_resumes_exactly():
    by_id = _run(SMALL, 6)
    rnd = _run(SMALL.replace(species_order="random"), 6)
    assert [sp.members for sp in by_id.species] != [sp.members for sp in rnd.species]
    # resume: the salt is part of the state
    half = _run(SMALL.replace(species_order="random"), 3)
    saved = json.loads(json.dumps(half.to_dict()))
    assert isinstance(saved["species_order_salt"], int)
    resumed = Population.from_dict(saved)
    rng = np.random.default_rng(2)
    for _ in range(3):
        rng.uniform(1, 5, 60)  # the fitness draws of the first three generations
    for _ in range(3):
        resumed.tell(rng.uniform(1, 5, 60))
    assert json.dumps(resumed.to_dict()) == json.dumps(rnd.to_dict())
    # the id order draws no salt, so its random stream and files are unchanged
    assert "species_order_salt" not in by_id.to_dict()
    bad = dict(saved)
    del bad["species_order_salt"]
    with pytest.raises(ValueError, match="species_order_salt"):
        Population.from_dict(bad)


# ------------------------------------------------------------------ stagnation
STAG = NeatSettings(population_size=40, initial_compatibility_threshold=100.0, stagnation_generations=2)


def _species_means(settings, flags):
    from mahn_evo.neat.reproduction import stagnation_adjusted_means

    species = [Species(k, [2 * k, 2 * k + 1], 0, 1.0, 0, culled=c) for k, c in enumerate(flags)]
    f = np.arange(1.0, 2 * len(flags) + 1)
    return stagnation_adjusted_means(species, f, champion=len(flags) - 1, generation=10, settings=settings)


def test_sticky_penalises_exactly_the_flagged_species_recompute_the_stale_non_champions():
    sticky = _species_means(STAG.replace(stagnation_rule="sticky"), [True, False, True])
    assert sticky.tolist() == [1.5 * 0.01, 3.5, 5.5 * 0.01]  # the flag decides, not the clock
    recompute = _species_means(STAG, [True, False, True])
    assert recompute.tolist() == [1.5 * 0.01, 3.5 * 0.01, 5.5]  # every stale species but the champion


def test_sticky_flag_stays_after_an_improvement_and_the_lone_champion_is_pardoned():
    pop = Population.create(STAG.replace(stagnation_rule="sticky"), seed=1, kind="iros2011", n_inputs=6)
    assert len(pop.species) == 1
    f = np.full(40, 2.0)
    for _ in range(4):  # no improvement for more than 2 generations: flagged, but it is the champion: pardoned
        pop.tell(f)
    sp = pop.species[0]
    assert not sp.culled and sp.last_improvement == 3  # the clock restarted at the pardon
    # a flagged species stays flagged when it improves (the original's sticky CullCandidateFlag)
    flagged = Species(9, [0], 0, 1.0, 0, culled=True)
    assert Species.from_dict(json.loads(json.dumps(flagged.to_dict()))).culled
    assert "culled" not in Species(9, [0], 0, 1.0, 0).to_dict()


def test_sticky_rule_resumes_exactly():
    s = SMALL.replace(stagnation_generations=1)
    sticky = _run(s.replace(stagnation_rule="sticky"), 8)
    half = _run(s.replace(stagnation_rule="sticky"), 4)
    resumed = Population.from_dict(json.loads(json.dumps(half.to_dict())))
    rng = np.random.default_rng(2)
    for _ in range(4):
        rng.uniform(1, 5, 60)
    for _ in range(4):
        resumed.tell(rng.uniform(1, 5, 60))
    assert json.dumps(resumed.to_dict()) == json.dumps(sticky.to_dict())


# ------------------------------------------------------------------ presets
def test_presets_set_the_originals_fields_and_flags_still_override():
    code = apply_preset(EvolutionConfig(), "iros2011-code")
    assert (code.init, code.evaluate_modules, code.cppn_activation) == ("iros2011", False, "recursive")
    assert (code.neat.species_order, code.neat.stagnation_rule, code.neat.weight_coefficient) == \
        ("random", "sticky", 0.05)
    paper = apply_preset(EvolutionConfig(), "iros2011-paper")
    assert paper.init == "minimal" and paper.neat.weight_coefficient == 0.1
    assert apply_preset(EvolutionConfig(), "iros2011-code").with_overrides(pop=50).neat.population_size == 50
    with pytest.raises(ValueError, match="unknown preset"):
        apply_preset(EvolutionConfig(), "iros2012")
    multistep = apply_preset(EvolutionConfig(), "iros2011-multistep")
    assert (multistep.init, multistep.evaluate_modules, multistep.cppn_activation) == ("iros2011", True, "relax")
    assert (multistep.neat.species_order, multistep.neat.stagnation_rule) == (code.neat.species_order,
                                                                              code.neat.stagnation_rule)
    assert set(PRESETS) == {"iros2011-code", "iros2011-multistep", "iros2011-paper", "hardened", "best-restarts",
                            "hardened-sequential"}


def test_the_hardened_sequential_preset_is_the_nfb1s_command():
    """`--preset hardened-sequential` plans exactly the experiment written out flag by flag
    (docs/results/selection/nfb1s.md), so its runs are those runs."""
    from mahn_evo.cli import build_parser, experiment_plan

    common = "experiment --out x --modes situational --runs 15 --seed 1 --generations 1000 --after-solved 150"
    flags = (" --preset best-restarts --noise generalization --episodes 3 --noise-draws per_generation "
             "--noise-free-episode --aggregate mean --map-branch 49 --branch-sides one_short --plain-episodes 1 "
             "--sequential-episodes 2 --sequential-plain 1 --noise-free-branch 49 --robust-from first_solution "
             "--robust-delay 50 --fitness-memory lifetime")
    spelled = experiment_plan(build_parser().parse_args((common + flags).split()))
    preset = experiment_plan(build_parser().parse_args((common + " --preset hardened-sequential").split()))
    assert preset == spelled
    config = apply_preset(EvolutionConfig(), "hardened-sequential")
    assert (config.robust_from, config.noise_free_branch, config.fitness_memory) == ("first_solution", 49.0,
                                                                                     "lifetime")
    assert config.task.sensor_noise > 0 and config.evaluation.sequential_plain == 1


def test_cli_preset_reaches_the_run_config(tmp_path):
    from mahn_evo.cli import main

    out = tmp_path / "run"
    assert main(["train", "--preset", "iros2011-code", "--generations", "1", "--pop", "20", "--quiet",
                 "--out", str(out)]) == 0
    cfg = json.loads((out / "config.json").read_text())
    assert cfg["evaluate_modules"] is False and cfg["neat"]["species_order"] == "random"
    assert cfg["neat"]["stagnation_rule"] == "sticky"
    # the code-faithful start: every initial team is the all-forward team (modules dead, x1/x2/z inert)
    first = (out / "log.csv").read_text().splitlines()[1].split(",")
    assert float(first[2]) == pytest.approx(2.0232671157474, abs=1e-9) == float(first[3])


def test_the_relaxations_vector_activations_are_the_scalar_ones_bit_for_bit():
    """Bipolar sigmoid, gaussian and sigmoid run as 64-lane vectors in the relaxation (`expf_ir`), and sin(2x)
    as glibc's sinf in vector form (`sinf.sin2x_ir`; rows with an argument beyond +-120 go through the library):
    on a million random float32 bit patterns, a million CPPN-sized values, the points around multiples of pi/8
    (where the sine's reduction changes quadrant) and the special values they equal `_activate` bit for bit
    (NaN stays NaN).  benchmarks/check_expf.py checks every float32."""
    from numba import njit

    from mahn_evo.cppn.relax import LANES, _activate, activate_row

    @njit
    def vector(code, x):
        block = x.reshape(-1, LANES).copy()
        for i in range(block.shape[0]):
            activate_row(block, i, code)
        return block.reshape(-1)

    @njit
    def scalar(code, x):
        out = np.empty_like(x)
        for i in range(x.shape[0]):
            out[i] = _activate(code, x[i])
        return out

    rng = np.random.default_rng(0)
    special = np.array([0.0, -0.0, np.inf, -np.inf, np.nan, 1e-45, -1e-45, 88.0, -88.0, -103.3, -104.0, 3.4e38,
                        -3.4e38, 17.8, -17.8, 1.0], dtype=np.float32)
    quadrants = (np.arange(-96, 96) * np.pi / 16).astype(np.float32)
    x = np.concatenate([rng.integers(0, 2**32, 2**20, dtype=np.uint64).astype(np.uint32).view(np.float32),
                        rng.uniform(-60, 60, 2**20).astype(np.float32), np.tile(special, LANES // special.size),
                        quadrants, np.nextafter(quadrants, np.float32(np.inf)),
                        np.nextafter(quadrants, np.float32(-np.inf))])
    for code in (0, 1, 3, 7):
        a, b = vector(code, x), scalar(code, x)
        same = (a.view(np.uint32) == b.view(np.uint32)) | (np.isnan(a) & np.isnan(b))
        assert same.all(), (code, x[~same][:5])


def test_the_population_relaxed_over_the_cores_is_bit_for_bit_plan_by_plan():
    """`relax_population` (genomes in a parallel loop, the route decode takes) gives every plan's own outputs, for
    grown recurrent CPPNs with modules of different sizes, at one thread and at two."""
    import numba

    from mahn_evo.cppn.batch import evaluate_plans
    from mahn_evo.cppn.relax import relax_population

    plans = [compile_relax(random_genome(s, steps=40, kind="iros2011")) for s in range(12)]
    plans.append(compile_relax(iros2011_seed_genome(6)))
    assert len({p.act.size for p in plans}) > 3 and any(p.mod_out.size for p in plans)
    q = _queries(6, n=37)
    alone = np.stack([p.evaluate(q) for p in plans])
    before = numba.get_num_threads()
    try:
        for n in sorted({1, numba.config.NUMBA_NUM_THREADS}):
            numba.set_num_threads(n)
            assert np.array_equal(relax_population(plans, q).view(np.uint32), alone.view(np.uint32))
    finally:
        numba.set_num_threads(before)
    assert np.array_equal(evaluate_plans(plans, q).view(np.uint32), alone.view(np.uint32))
    with pytest.raises(ValueError, match="expected inputs of shape"):
        relax_population(plans, q[:, :5])
    with pytest.raises(ValueError, match="no plans"):
        relax_population([], q)
