"""Map-spread training (`--map-spread S`): keyed episodes on plus variants with arms of other lengths."""
from __future__ import annotations

import numpy as np
import pytest

from mahn_envs.core import BatchSim
from mahn_envs.maps import load_map
from mahn_envs.maps.variants import PLUS_ARM, plus_variant, spread_variant
from mahn_evo.cli import build_parser, experiment_plan
from mahn_evo.experiment.report import _robust_text
from mahn_evo.hyperneat.evaluation_settings import EvaluationSettings
from mahn_evo.hyperneat.team_evaluator import TeamEvaluator
from mahn_evo.training.config import EvolutionConfig
from mahn_evo.training.presets import apply_preset
from mahn_evo.training.trainer import Trainer


def _segments(walls: np.ndarray) -> list:
    return sorted(tuple(sorted([(round(w[0], 9), round(w[1], 9)), (round(w[2], 9), round(w[3], 9))])) for w in walls)


def test_the_variant_with_the_plus_arms_is_the_plus_map():
    plus, same = load_map("plus"), plus_variant(PLUS_ARM, PLUS_ARM, PLUS_ARM)
    assert _segments(same.walls) == _segments(plus.walls)
    assert np.array_equal(same.pois, plus.pois) and np.array_equal(same.home, plus.home)
    assert np.array_equal(same.starts, plus.starts)


def test_a_variant_moves_each_end_wall_and_its_post_with_its_arm():
    v = plus_variant(50.0, 100.0, 120.0)
    plus = load_map("plus")
    xmin, ymin, xmax, ymax = v.bounds
    assert (xmin, ymin) == pytest.approx((78.74 - 50.0, 0.0)) and (xmax, ymax) == pytest.approx(
        (108.2675 + 120.0, 108.2675 + 100.0))
    assert v.pois - plus.pois == pytest.approx(np.array([[PLUS_ARM - 50.0, 0], [0, 100.0 - PLUS_ARM],
                                                         [120.0 - PLUS_ARM, 0]]))
    for bad in (10.0, -5.0, float("nan"), True, "60"):
        with pytest.raises(ValueError, match="arm must be a length"):
            plus_variant(bad, 60.0, 60.0)


def test_spread_variants_are_a_pure_function_of_seed_and_key():
    a, b = spread_variant(3, 7, 0.3), spread_variant(3, 7, 0.3)
    assert np.array_equal(a.walls, b.walls)
    assert not np.array_equal(a.walls, spread_variant(3, 8, 0.3).walls)
    assert not np.array_equal(a.walls, spread_variant(4, 7, 0.3).walls)
    for key in range(40):  # the three arms stay within [1 - S, 1 + S] of the plus map's
        xmin, _, xmax, ymax = spread_variant(0, key, 0.3).bounds
        arms = np.array([78.74 - xmin, ymax - 108.2675, xmax - 108.2675])
        assert np.all(arms >= 0.7 * PLUS_ARM - 1e-9) and np.all(arms <= 1.3 * PLUS_ARM + 1e-9)
    assert np.array_equal(spread_variant(0, 0, 0.0).walls, load_map("plus").walls)  # no spread: the plus map
    for bad in (1.0, -0.1, True):
        with pytest.raises(ValueError, match="spread must be"):
            spread_variant(0, 0, bad)


def test_each_keyed_episode_is_played_on_its_variant_and_the_clean_one_on_plus(tmp_path):
    cfg = apply_preset(EvolutionConfig(seed=5, init="minimal"), "hardened").with_overrides(
        pop=8, robust_from="start", robust_delay=0, map_spread=0.3)
    genomes = Trainer(cfg, tmp_path).population.ask()
    ev = TeamEvaluator(cfg.evaluation)
    ctrl = ev.decode(genomes)
    fitness, _ = ev.score(ctrl, generation=2)
    keys = ev.episode_keys(2)
    assert keys == [6, 7, 8]
    n = len(genomes)
    expected = np.zeros(n)
    for key in keys:  # each noisy episode on the variant of its key, played directly in the core
        sim = BatchSim(spread_variant(cfg.seed, key, 0.3), n, cfg.task)
        expected += sim.run_controllers(ctrl, seed=cfg.seed, episode_keys=np.full(n, key, dtype=np.int64)).fitness
    clean = BatchSim("plus", n, cfg.task.without_noise())
    expected += clean.run_controllers(ctrl, seed=cfg.seed, episode_keys=np.zeros(n, dtype=np.int64)).fitness
    assert fitness == pytest.approx(expected / 4, abs=1e-12)
    # without the spread the same teams score otherwise: the variants are really played
    plain, _ = TeamEvaluator(EvaluationSettings(**{**cfg.evaluation.__dict__, "map_spread": 0.0})).score(ctrl, 2)
    assert not np.allclose(plain, fitness)


def test_the_spread_is_checked_and_stays_out_of_the_noise_free_phase():
    with pytest.raises(ValueError, match="map_spread must be a number"):
        EvaluationSettings(map_spread=1.5)
    with pytest.raises(ValueError, match="needs map 'plus'"):
        EvaluationSettings(map="asymmetric_plus", map_spread=0.3)
    cfg = apply_preset(EvolutionConfig(), "hardened").with_overrides(map_spread=0.3)
    assert cfg.evaluation.map_spread == 0.3
    assert cfg.noise_free_evaluation.map_spread == 0.0  # before the robust phase: the faithful run, bit for bit
    assert EvolutionConfig.from_mapping(cfg.to_dict()).map_spread == 0.3


def test_the_experiment_flag_reaches_every_run_and_the_report():
    args = build_parser().parse_args(["experiment", "--preset", "hardened", "--map-spread", "0.3",
                                      "--after-solved", "250", "--out", "x"])
    plan = experiment_plan(args)
    assert plan.map_spread == 0.3
    assert plan.train_config("situational", 3).map_spread == 0.3
    text = _robust_text(plan.to_dict())
    assert "plus variant with arm lengths x [0.7, 1.3]" in text and "noise-free episode on the map itself" in text


def test_the_published_map_spread_experiment_is_the_documented_command():
    from pathlib import Path

    from mahn_evo.experiment.plan import ExperimentPlan

    published = ExperimentPlan.load(Path(__file__).parents[2] / "docs" / "results" / "experiment_harden_maps")
    args = build_parser().parse_args(["experiment", "--modes", "situational", "--runs", "15", "--seed", "1",
                                      "--preset", "hardened", "--map-spread", "0.3", "--after-solved", "250"])
    assert experiment_plan(args) == published
