"""Robust evaluation: K noisy episodes per team, common random numbers per generation, mean/min/quantile."""
from __future__ import annotations

import csv

import numpy as np
import pytest

from mahn_evo.hyperneat.evaluation_settings import EvaluationSettings
from mahn_evo.hyperneat.team_evaluator import TeamEvaluator
from mahn_evo.neat import NeatSettings, Population
from mahn_evo.training.config import EvolutionConfig
from mahn_evo.training.trainer import Trainer, train

NOISY = EvolutionConfig().with_noise("generalization").task


def _evaluator(**settings) -> TeamEvaluator:
    return TeamEvaluator(EvaluationSettings(**settings))


def _genomes(n=12, seed=4):
    return Population.create(NeatSettings(population_size=n), seed=seed, kind="iros2011", n_inputs=6).ask()


def test_per_generation_draws_are_common_to_the_teams_and_new_each_generation():
    ev = _evaluator(task=NOISY, episodes=3, noise_draws="per_generation", evaluate_modules=True)
    assert ev.episode_keys(0) == [0, 1, 2] and ev.episode_keys(5) == [15, 16, 17]
    fixed = _evaluator(task=NOISY, episodes=3, evaluate_modules=True)
    assert fixed.episode_keys(5) == [0, 1, 2]
    g = _genomes()
    twins = [g[0]] * 4 + g[4:]  # identical teams in one generation meet identical episodes
    e0 = ev.evaluate(twins, generation=0)
    assert len(set(e0.fitness[:4].tolist())) == 1
    e1 = ev.evaluate(twins, generation=1)
    assert not np.array_equal(e0.fitness, e1.fitness)  # fresh draws
    np.testing.assert_array_equal(ev.evaluate(twins, generation=1).fitness, e1.fitness)  # but keyed


def test_aggregates_order_min_quantile_mean():
    g = _genomes()
    kw = dict(task=NOISY, episodes=4, noise_draws="per_generation", evaluate_modules=True)
    mean = _evaluator(**kw).evaluate(g, 2).fitness
    q = _evaluator(aggregate="quantile", quantile=0.25, **kw).evaluate(g, 2).fitness
    low = _evaluator(aggregate="min", **kw).evaluate(g, 2).fitness
    assert np.all(low <= q + 1e-12) and np.all(q <= mean + 1e-9)
    assert np.any(low < mean)
    with pytest.raises(ValueError, match="aggregate"):
        EvaluationSettings(aggregate="median")


def _robust(**kw):
    base = dict(generations=4, seed=5, episodes=2, noise_draws="per_generation", aggregate="min")
    base.update(kw)
    return EvolutionConfig(**base).with_overrides(pop=24).with_noise("generalization")


def test_robust_training_is_deterministic_and_resumes_bit_identically(tmp_path):
    full = train(_robust(generations=4), tmp_path / "full")
    part = Trainer(_robust(generations=2), tmp_path / "part")
    part.run()
    resumed = train(_robust(generations=4), tmp_path / "part", resume=True)
    assert full["best_fitness"] == resumed["best_fitness"]
    with open(tmp_path / "full" / "log.csv") as a, open(tmp_path / "part" / "log.csv") as b:
        ra, rb = list(csv.reader(a)), list(csv.reader(b))
    assert [r[:10] for r in ra] == [r[:10] for r in rb]
    assert int(ra[-1][1]) == 4 * 24 * 2  # evaluations count every episode


def test_noise_preset_is_saved_in_the_run_config(tmp_path):
    cfg = _robust()
    assert cfg.task.sensor_noise == 5.0 and cfg.task.effector_noise == 10.0
    assert EvolutionConfig.from_mapping(cfg.to_dict()) == cfg
    assert cfg.with_noise("none").task == EvolutionConfig().task


def test_a_noise_free_episode_joins_the_noisy_ones():
    g = _genomes()
    kw = dict(task=NOISY, episodes=2, noise_draws="per_generation", evaluate_modules=True)
    both = _evaluator(noise_free_episode=True, **kw)
    noisy = _evaluator(**kw).evaluate(g, 3)
    clean = _evaluator(evaluate_modules=True).evaluate(g, 3)
    np.testing.assert_allclose(both.evaluate(g, 3).fitness, (2 * noisy.fitness + clean.fitness) / 3, rtol=1e-12)
    low = _evaluator(noise_free_episode=True, aggregate="min", **kw).evaluate(g, 3).fitness
    assert np.all(low <= clean.fitness) and np.all(low <= noisy.fitness + 1e-9)
    cfg = EvolutionConfig(noise_free_episode=True)
    assert EvolutionConfig.from_mapping(cfg.to_dict()).noise_free_episode is True
    with pytest.raises(TypeError, match="noise_free_episode"):
        EvolutionConfig(noise_free_episode="yes")
