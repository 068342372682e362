"""Direct-encoding NEAT: mahn's NEAT on the substrate networks through the trainer's evaluator; beats a random
team, resumes bit-identically, refuses a damaged checkpoint."""
from __future__ import annotations

import json

import numpy as np
import pytest

from baselines.comparison.compare import evo_curve
from baselines.direct.cmaes import DirectEncoding
from baselines.direct.neat import DirectNEAT, NeatDirectConfig, SubstrateGenes, train
from mahn_envs.core.batch import BatchSim
from mahn_envs.core.params import TaskParams
from mahn_evo.neat import Genome, NeatSettings

SHORT = dict(max_cycles=300, signal_tick=150)
TINY = dict(max_cycles=60, signal_tick=30)


@pytest.mark.parametrize("mode,n", [("standard", 549), ("situational", 1044)])
def test_genes_land_on_the_substrate_connections_as_cma_es_encodes_them(mode, n):
    genes = SubstrateGenes(mode)
    assert genes.n_params == n and int((genes.place >= 0).sum()) == n  # one (source, target) per parameter
    settings = NeatSettings(population_size=3, add_node_probability=0.0)
    genomes, tracker = genes.initial_population(settings, "full", np.random.default_rng(0))
    for g in genomes:
        g.validate()
    assert tracker.next_id == genes.n_nodes + n
    x, expressed = genes.parameters(genomes, settings.weight_limit)
    assert np.all(expressed == n)
    # the gene order is DirectEncoding's parameter order, weights scaled from NEAT's +-1.5 to the substrate's +-3
    assert np.array_equal(x, np.stack([2.0 * g.weight for g in genomes]))
    ctrl, _ = genes.decode(genomes, settings.weight_limit)
    ref = DirectEncoding(mode).decode(x)
    for f in ("w_ih", "w_hh", "w_ho", "b_h", "b_o"):
        assert np.array_equal(getattr(ctrl, f), getattr(ref, f))
    # robot 1, brain 0: bias -> its first hidden node is b_h, its hidden 2 -> hidden 5 is w_hh[5, 2]
    first = 1 + genes.n_inputs + (12 * (2 if mode == "situational" else 1))
    g = genomes[0]
    w = dict(zip(zip(g.src.tolist(), g.dst.tolist()), g.weight.tolist()))
    assert ctrl.b_h[0, 1, 0, 0] == np.float32(2 * w[(0, first)])
    assert ctrl.w_hh[0, 1, 0, 5, 2] == np.float32(2 * w[(first + 2, first + 5)])


def test_genes_that_are_no_substrate_connection_do_nothing():
    genes = SubstrateGenes("standard")
    settings = NeatSettings(population_size=2, add_node_probability=0.0)
    (g, _), _ = genes.initial_population(settings, "feedforward", np.random.default_rng(1))
    assert g.n_connections == 549 - 3 * 81  # no recurrent hidden links
    out0 = 1 + 7 + 9  # robot 0's first output node
    hidden1 = 1 + 7 + 12  # robot 1's first hidden node
    extra = Genome(g.nodes, np.append(g.innov, [900, 901]), np.append(g.src, [1, out0]),
                   np.append(g.dst, [out0, hidden1]), np.append(g.weight, [1.0, -1.0]))
    extra.validate()
    a, ea = genes.parameters([g], 1.5)
    b, eb = genes.parameters([extra], 1.5)
    assert np.array_equal(a, b) and ea[0] == eb[0] == 306


def test_a_short_run_beats_a_random_team(tmp_path):
    """5 generations of 40 teams on the 300-tick task beat a random team (0.086) several times over."""
    cfg = NeatDirectConfig(mode="situational", generations=5, popsize=40, seed=0, **SHORT)
    summary = train(cfg, tmp_path / "run")
    random_fitness = BatchSim("plus", 64, TaskParams(**SHORT)).run_random(seed=0).fitness.mean()
    assert summary["best_fitness"] > 2 * random_fitness
    assert summary["evaluations"] == 200 and summary["robot_steps"] == 200 * 300 * 3
    best = json.loads((tmp_path / "run" / "best_controllers.json").read_text())
    assert best["fitness"] == summary["best_fitness"] and len(best["genome"]["connections"]) == 1044
    # the comparison reads the run like an evolution run, under its own method name
    curve = evo_curve(tmp_path / "run", ticks=300)
    assert curve.method == "neat_direct_situational" and curve.budget[-1] == 200 * 300 * 3


def _state(folder):
    data = json.loads((folder / "checkpoint.json").read_text())
    return data["population"], [r[:-2] for r in data["log"]]  # all but the CPU and wall seconds


def test_resume_is_bit_identical(tmp_path):
    base = dict(mode="standard", popsize=12, seed=4, start="feedforward",
                neat={"add_connection_probability": 0.5}, **TINY)
    train(NeatDirectConfig(generations=6, **base), tmp_path / "straight", checkpoint_every=2)
    train(NeatDirectConfig(generations=3, **base), tmp_path / "resumed", checkpoint_every=2)
    train(NeatDirectConfig(generations=6, **base), tmp_path / "resumed", resume=True, checkpoint_every=2)
    straight, resumed = _state(tmp_path / "straight"), _state(tmp_path / "resumed")
    assert straight == resumed and straight[0]["generation"] == 6
    # add-connection grew recurrent links (more expressed genes than the feed-forward start's 306)
    assert max(r[9] for r in straight[1]) > 306
    train(NeatDirectConfig(generations=6, **{**base, "seed": 5}), tmp_path / "other")
    assert _state(tmp_path / "other") != straight


def test_a_damaged_checkpoint_is_refused_by_name(tmp_path):
    base = dict(mode="standard", popsize=4, seed=0, **TINY)
    train(NeatDirectConfig(generations=2, **base), tmp_path / "run")
    ckpt = tmp_path / "run" / "checkpoint.json"
    text = ckpt.read_text()
    ckpt.write_text(text.replace('"generation":2', '"generation":3', 1))
    with pytest.raises(ValueError, match=r"checkpoint\.json.*damaged"):
        DirectNEAT(NeatDirectConfig(generations=4, **base), tmp_path / "run", resume=True)
    ckpt.write_text(text[: len(text) // 2])
    with pytest.raises(ValueError, match=r"checkpoint\.json.*corrupt"):
        DirectNEAT(NeatDirectConfig(generations=4, **base), tmp_path / "run", resume=True)


def test_resume_refuses_other_settings(tmp_path):
    base = dict(mode="standard", popsize=4, seed=0, **TINY)
    train(NeatDirectConfig(generations=2, **base), tmp_path / "run")
    with pytest.raises(ValueError, match="popsize"):
        DirectNEAT(NeatDirectConfig(generations=4, **{**base, "popsize": 8}), tmp_path / "run", resume=True)
    with pytest.raises(ValueError, match="neat"):
        DirectNEAT(NeatDirectConfig(generations=4, neat={"weight_jiggle": 0.1}, **base), tmp_path / "run",
                   resume=True)
    with pytest.raises(ValueError, match="already holds a run"):
        DirectNEAT(NeatDirectConfig(generations=4, **base), tmp_path / "run")


def test_config_rejects_bad_settings():
    with pytest.raises(ValueError, match="mode"):
        NeatDirectConfig(mode="hybrid")
    with pytest.raises(ValueError, match="start"):
        NeatDirectConfig(start="empty")
    with pytest.raises(ValueError, match="add_node_probability"):
        NeatDirectConfig(neat={"add_node_probability": 0.1})
    with pytest.raises(ValueError, match="weight_jigle"):
        NeatDirectConfig(neat={"weight_jigle": 0.1})
    assert NeatDirectConfig(start="full").neat_settings.add_connection_probability == 0.0
    assert NeatDirectConfig(start="feedforward").neat_settings.add_connection_probability == 0.03


def test_cli_neat_direct_starts_then_resumes_with_one_command(tmp_path):
    from baselines.cli import main

    args = ["neat-direct", "--mode", "standard", "--popsize", "6", "--seed", "2", "--out", str(tmp_path / "run"),
            "--resume", "--max-cycles", "60", "--signal-tick", "30", "--neat", '{"weight_jiggle": 0.1}']
    assert main(args + ["--generations", "2"]) == 0
    assert main(args + ["--generations", "3"]) == 0
    summary = json.loads((tmp_path / "run" / "summary.json").read_text())
    assert summary["generations"] == 3 and summary["method"] == "neat_direct_standard"
    config = json.loads((tmp_path / "run" / "config.json").read_text())
    assert config["generations"] == 3 and config["neat_settings"]["weight_jiggle"] == 0.1


def test_the_initial_threshold_is_the_initial_genomes_distance(tmp_path):
    """NEAT's threshold 8 is the scale of small CPPNs: 1044 genes at 8 would make every genome its own species."""
    cfg = NeatDirectConfig(mode="situational", popsize=40, generations=1, **TINY)
    assert cfg.neat_settings.initial_compatibility_threshold == pytest.approx(0.05 * 1044 * 1.0)
    assert NeatDirectConfig(start="feedforward", mode="standard").neat_settings.initial_compatibility_threshold \
        == pytest.approx(0.05 * 306)
    mean_rule = NeatDirectConfig(neat={"weight_difference_mean": True}).neat_settings
    assert mean_rule.initial_compatibility_threshold == pytest.approx(0.05)
    assert NeatDirectConfig(neat={"initial_compatibility_threshold": 8.0}).neat_settings \
        .initial_compatibility_threshold == 8.0
    scaled = DirectNEAT(cfg, tmp_path / "scaled").population
    nominal = DirectNEAT(NeatDirectConfig(mode="situational", popsize=40, generations=1,
                                          neat={"initial_compatibility_threshold": 8.0}, **TINY),
                         tmp_path / "nominal").population
    assert len(nominal.species) == 40 and len(scaled.species) < 40
