"""fitness_memory "lifetime": under fresh noisy draws each generation, a team's fitness is the mean of its scores over
every generation the same genome was scored in, the archive keeps new leaders that solved every episode of at least
LIFETIME_MIN_GENERATIONS generations, and a resumed run is the uninterrupted one."""
from __future__ import annotations

import json
from dataclasses import replace

import numpy as np
import pytest

from mahn_evo.cli import build_parser, experiment_plan
from mahn_evo.experiment.plan import ExperimentPlan
from mahn_evo.neat.population import Population
from mahn_evo.training.champion import Champion
from mahn_evo.training.config import EvolutionConfig
from mahn_evo.training.lifetime import LIFETIME_MIN_GENERATIONS, LifetimeScores, genome_digest
from mahn_evo.training.trainer import Trainer


def _config(**kw) -> EvolutionConfig:
    cfg = EvolutionConfig(generations=5, seed=11, episodes=2, noise_draws="per_generation").with_overrides(pop=24)
    return replace(cfg.with_noise("generalization"), **{"fitness_memory": "lifetime", **kw})


def _three_genomes():
    """Two genomes of an initial population and a third that differs from the first in its weights."""
    pop = Population.create(EvolutionConfig().with_overrides(pop=24).neat, seed=3, kind="minimal", n_inputs=6)
    g = pop.ask()
    a, b = g[0], g[1]
    c = a.with_weights(a.weight + 0.5)
    return a, b, c


def test_scores_are_averaged_over_generations_counted_once_per_generation_and_forgotten():
    a, b, c = _three_genomes()
    life = LifetimeScores()
    mean, n, ok = life.update([a, b, a], np.array([10.0, 20.0, 10.0]), np.array([True, False, True]))
    assert mean.tolist() == [10.0, 20.0, 10.0] and n.tolist() == [1, 1, 1] and ok.tolist() == [True, False, True]
    mean, n, ok = life.update([a, c], np.array([30.0, 5.0]), np.array([True, True]))
    assert mean.tolist() == [20.0, 5.0] and n.tolist() == [2, 1] and ok.tolist() == [True, True]
    mean, n, ok = life.update([b, a], np.array([40.0, 0.0]), np.array([True, False]))
    assert mean.tolist() == [40.0, 40.0 / 3] and n.tolist() == [1, 3]  # b was not in the last generation
    assert ok.tolist() == [True, False]  # one unsolved generation and a team is no longer solved in all
    assert genome_digest(a) == genome_digest(a.with_weights(a.weight.copy())) != genome_digest(c)


def test_the_records_survive_a_checkpoint_and_a_bad_record_is_named():
    a, b, c = _three_genomes()
    life = LifetimeScores()
    life.update([a, b], np.array([10.0, 20.0]), np.array([True, True]))
    life.update([a], np.array([30.0]), np.array([True]))
    rows = life.to_list([a, c])
    assert rows == [[40.0, 2, True], None]
    back = LifetimeScores.from_list([a, c], json.loads(json.dumps(rows)))
    assert back.update([a, c], np.array([0.0, 1.0]), np.array([True, True]))[1].tolist() == [3, 1]
    for bad in ([[1.0, 0, True], None], [[1.0, 2, "yes"], None], [[1.0, 2]], "x"):
        with pytest.raises(ValueError, match="lifetime"):
            LifetimeScores.from_list([a, c], bad)


def test_the_archive_keeps_each_new_leader_after_enough_solved_generations(tmp_path):
    trainer = Trainer(_config(), tmp_path / "run")
    genomes = trainer.population.ask()
    ev = trainer.evaluator.evaluate(genomes, 0)
    n = len(genomes)
    archive = tmp_path / "run" / "archive"
    solved = np.ones(n, dtype=bool)
    scores = np.linspace(1.0, 2.0, n)  # the last team leads every generation
    for gen in range(LIFETIME_MIN_GENERATIONS):
        assert not archive.exists()
        fit = trainer._archive_lifetime_leader(gen, genomes, replace(ev, fitness=scores + gen), solved)
    files = sorted(archive.glob("*.json"))
    assert len(files) == 1 and files[0].name == f"solution_g{LIFETIME_MIN_GENERATIONS - 1:05d}_i{n - 1:04d}.json"
    champ = Champion.load(files[0])
    assert champ.fitness == pytest.approx(2.0 + (LIFETIME_MIN_GENERATIONS - 1) / 2)  # its lifetime mean
    assert fit[n - 1] == pytest.approx(champ.fitness)
    trainer._archive_lifetime_leader(9, genomes, replace(ev, fitness=scores), solved)
    assert len(list(archive.glob("*.json"))) == 1  # the same leader is not archived again
    # a team that failed an episode once is never archived; the next best takes the lead
    trainer._archive_lifetime_leader(10, genomes, replace(ev, fitness=scores), np.arange(n) != n - 1)
    assert sorted(p.name for p in archive.glob("*.json"))[-1] == f"solution_g00010_i{n - 2:04d}.json"
    assert trainer.last_archived == genome_digest(genomes[n - 2])


def test_selection_uses_the_lifetime_mean_and_a_resumed_run_is_the_uninterrupted_one(tmp_path):
    straight = Trainer(_config(), tmp_path / "a")
    straight.run()
    plain = Trainer(_config(fitness_memory="generation"), tmp_path / "p")
    plain.run()
    assert straight.rows[0][:-1] == plain.rows[0][:-1]  # the same first generation
    assert [r[:-1] for r in straight.rows] != [r[:-1] for r in plain.rows]  # then other parents
    stopped = Trainer(replace(_config(), generations=3), tmp_path / "b")
    stopped.run()
    saved = json.loads((tmp_path / "b" / "checkpoint.json").read_text())["trainer"]
    assert any(r is not None and r[1] >= 2 for r in saved["lifetime"])  # elites carry their records over
    resumed = Trainer(_config(), tmp_path / "b", resume=True)
    resumed.run()
    assert [r[:-1] for r in resumed.rows] == [r[:-1] for r in straight.rows]
    assert resumed.lifetime.to_list(resumed.population.genomes) == straight.lifetime.to_list(
        straight.population.genomes)


def test_archive_mode_selects_by_the_generation_score_and_keeps_the_lifetime_records(tmp_path):
    """fitness_memory "archive" is the "generation" run bit for bit (NEAT sees the same fitness), with the lifetime
    records kept for the archive's leaders, and it resumes to the uninterrupted run."""
    archive = Trainer(_config(fitness_memory="archive"), tmp_path / "a")
    archive.run()
    plain = Trainer(_config(fitness_memory="generation"), tmp_path / "p")
    plain.run()
    assert [r[:-1] for r in archive.rows] == [r[:-1] for r in plain.rows]
    records = archive.lifetime.to_list(archive.population.genomes)
    assert any(r is not None for r in records)  # the next generation's elites carry theirs
    stopped = Trainer(replace(_config(fitness_memory="archive"), generations=3), tmp_path / "b")
    stopped.run()
    resumed = Trainer(_config(fitness_memory="archive"), tmp_path / "b", resume=True)
    resumed.run()
    assert [r[:-1] for r in resumed.rows] == [r[:-1] for r in plain.rows]
    assert resumed.lifetime.to_list(resumed.population.genomes) == records


def test_lifetime_needs_fresh_noisy_draws_and_reaches_every_run_of_an_experiment():
    with pytest.raises(ValueError, match="fitness_memory must be one of"):
        _config(fitness_memory="forever")
    with pytest.raises(ValueError, match="per_generation"):
        _config(noise_draws="fixed")
    with pytest.raises(ValueError, match="fitness_memory 'archive'.*per_generation"):
        _config(noise_draws="fixed", fitness_memory="archive")
    with pytest.raises(ValueError, match="noisy task"):
        EvolutionConfig(noise_draws="per_generation", fitness_memory="lifetime")
    args = build_parser().parse_args(["experiment", "--out", "x", "--modes", "situational", "--noise",
                                      "generalization", "--episodes", "3", "--noise-draws", "per_generation",
                                      "--robust-from", "first_solution", "--after-solved", "10",
                                      "--fitness-memory", "lifetime"])
    plan = experiment_plan(args)
    assert plan.fitness_memory == "lifetime"
    assert plan.train_config("situational", 3).fitness_memory == "lifetime"
    assert ExperimentPlan().train_config("situational", 1).fitness_memory == "generation"
    args = build_parser().parse_args(["train", "--out", "x", "--noise", "generalization", "--episodes", "2",
                                      "--noise-draws", "per_generation", "--fitness-memory", "lifetime"])
    assert args.fitness_memory == "lifetime"
