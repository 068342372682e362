"""Map-branch training (`--map-branch B`): keyed episodes on plus variants whose side arms leave the top arm above
the crossing, so the crossing is not symmetric."""
from __future__ import annotations

import numpy as np
import pytest

from mahn_envs.core import BatchSim
from mahn_envs.maps import load_map
from mahn_envs.maps.variants import HIGH, LOW, PLUS_ARM, plus_variant, spread_variant
from mahn_evo.cli import build_parser, experiment_plan
from mahn_evo.experiment.report import _robust_text
from mahn_evo.hyperneat.team_evaluator import EvaluationSettings, TeamEvaluator
from mahn_evo.training.config import EvolutionConfig
from mahn_evo.training.presets import apply_preset
from mahn_evo.training.trainer import Trainer


def _side_openings(world) -> tuple[float, float]:
    """The y of the lower wall of the left and of the right arm (where each side arm leaves the top arm)."""
    walls = np.asarray(world.walls)
    horizontal = walls[np.isclose(walls[:, 1], walls[:, 3])]
    left = horizontal[(np.minimum(horizontal[:, 0], horizontal[:, 2]) < LOW - 1.0)][:, 1].min()
    right = horizontal[(np.maximum(horizontal[:, 0], horizontal[:, 2]) > HIGH + 1.0)][:, 1].min()
    return float(left), float(right)


def test_the_test_maps_geometry_is_a_branch_variant():
    """The asymmetric plus is the plus family's member with left 48.43, top and right 118.11 and the right arm 77.5
    above the crossing: same walls (as segments) and the same POIs up to the plus map's 0.5 cm POI offset."""
    v, asym = plus_variant(48.43, 118.11, 118.11, right_offset=77.5), load_map("asymmetric_plus")
    def segments(w):
        return np.array(sorted(tuple(np.ravel(sorted([tuple(s[:2]), tuple(s[2:])]))) for s in np.asarray(w.walls)))
    assert np.allclose(segments(v), segments(asym), atol=1e-6)
    assert np.allclose(v.pois, asym.pois, atol=0.51)


def test_branch_offsets_are_drawn_per_key_within_the_bound_and_keep_the_arm_lengths():
    seen = []
    for key in range(40):
        w = spread_variant(2, key, 0.0, 30.0)
        left, right = _side_openings(w)
        assert 0.0 <= left - LOW <= 30.0 + 1e-9 and 0.0 <= right - LOW <= 30.0 + 1e-9
        xmin, _, xmax, ymax = w.bounds
        assert np.allclose([LOW - xmin, ymax - HIGH, xmax - HIGH], PLUS_ARM)  # lengths: the plus map's
        seen.append((left, right))
    assert len(set(seen)) == 40 and spread_variant(2, 3, 0.0, 30.0).name == spread_variant(2, 3, 0.0, 30.0).name
    # with a spread too, the lengths are drawn first: a spread-only run's lengths do not change
    assert spread_variant(2, 3, 0.3, 20.0).bounds == spread_variant(2, 3, 0.3).bounds
    with pytest.raises(ValueError, match="map_branch must be"):
        spread_variant(0, 0, 0.0, 60.0)  # beyond the top arm less one corridor width
    with pytest.raises(ValueError, match="map_branch must be"):
        spread_variant(0, 0, 0.3, 30.0)  # the shortest top arm of spread 0.3 leaves room for 25.6 cm only
    with pytest.raises(ValueError, match="offset must be in"):
        plus_variant(78.74, 78.74, 78.74, left_offset=-1.0)


def test_keyed_episodes_are_played_on_branch_variants_and_the_clean_one_on_plus(tmp_path):
    cfg = apply_preset(EvolutionConfig(seed=4, init="minimal"), "hardened").with_overrides(
        pop=8, robust_from="start", robust_delay=0, map_branch=40.0)
    genomes = Trainer(cfg, tmp_path).population.ask()
    ev = TeamEvaluator(cfg.evaluation)
    ctrl = ev.decode(genomes)
    fitness, _ = ev.score(ctrl, generation=1)
    n = len(genomes)
    expected = np.zeros(n)
    for key in ev.episode_keys(1):
        sim = BatchSim(spread_variant(cfg.seed, key, 0.0, 40.0), n, cfg.task)
        expected += sim.run_controllers(ctrl, seed=cfg.seed, episode_keys=np.full(n, key, dtype=np.int64)).fitness
    expected += BatchSim("plus", n, cfg.task.without_noise()).run_controllers(
        ctrl, seed=cfg.seed, episode_keys=np.zeros(n, dtype=np.int64)).fitness
    assert fitness == pytest.approx(expected / 4, abs=1e-12)
    plain, _ = TeamEvaluator(EvaluationSettings(**{**cfg.evaluation.__dict__, "map_branch": 0.0})).score(ctrl, 1)
    assert not np.allclose(plain, fitness)


def test_plain_episodes_keep_the_first_keyed_episodes_of_each_generation_on_plus(tmp_path):
    cfg = apply_preset(EvolutionConfig(seed=4, init="minimal"), "hardened").with_overrides(
        pop=8, robust_from="start", robust_delay=0, map_branch=20.0, plain_episodes=1)
    genomes = Trainer(cfg, tmp_path).population.ask()
    ev = TeamEvaluator(cfg.evaluation)
    ctrl = ev.decode(genomes)
    n = len(genomes)
    for generation in (0, 5):
        fitness, _ = ev.score(ctrl, generation=generation)
        keys = ev.episode_keys(generation)
        assert keys[0] % cfg.episodes == 0
        expected = np.zeros(n)
        for i, key in enumerate(keys):
            world = "plus" if i == 0 else spread_variant(cfg.seed, key, 0.0, 20.0)
            expected += BatchSim(world, n, cfg.task).run_controllers(
                ctrl, seed=cfg.seed, episode_keys=np.full(n, key, dtype=np.int64)).fitness
        expected += BatchSim("plus", n, cfg.task.without_noise()).run_controllers(
            ctrl, seed=cfg.seed, episode_keys=np.zeros(n, dtype=np.int64)).fitness
        assert fitness == pytest.approx(expected / 4, abs=1e-12)
    all_variants, _ = TeamEvaluator(EvaluationSettings(**{**cfg.evaluation.__dict__, "plain_episodes": 0})).score(
        ctrl, 5)
    assert not np.allclose(all_variants, ev.score(ctrl, 5)[0])
    with pytest.raises(ValueError, match="plain_episodes must be"):
        EvaluationSettings(episodes=3, map_branch=20.0, plain_episodes=4)
    with pytest.raises(ValueError, match="plain_episodes keeps"):
        EvaluationSettings(episodes=3, plain_episodes=1)
    assert cfg.noise_free_evaluation.plain_episodes == 0
    args = build_parser().parse_args(["experiment", "--preset", "hardened", "--map-branch", "20",
                                      "--plain-episodes", "1", "--after-solved", "250", "--out", "x"])
    plan = experiment_plan(args)
    assert plan.plain_episodes == 1 and plan.train_config("situational", 2).plain_episodes == 1
    assert "the first 1 on the map itself (`--plain-episodes 1`), the others on a plus variant" in _robust_text(
        plan.to_dict())


def test_the_branch_is_checked_kept_out_of_the_noise_free_phase_and_reaches_the_report():
    with pytest.raises(ValueError, match="map_branch must be"):
        EvaluationSettings(map_branch=-5.0)
    with pytest.raises(ValueError, match="needs map 'plus'"):
        EvaluationSettings(map="asymmetric_plus", map_branch=20.0)
    cfg = apply_preset(EvolutionConfig(), "hardened").with_overrides(map_branch=40.0)
    assert cfg.evaluation.map_branch == 40.0 and cfg.noise_free_evaluation.map_branch == 0.0
    assert EvolutionConfig.from_mapping(cfg.to_dict()).map_branch == 40.0
    args = build_parser().parse_args(["experiment", "--preset", "hardened", "--map-branch", "40",
                                      "--after-solved", "250", "--out", "x"])
    plan = experiment_plan(args)
    assert plan.map_branch == 40.0 and plan.train_config("situational", 2).map_branch == 40.0
    text = _robust_text(plan.to_dict())
    assert "side arms leaving the top arm [0, 40] cm above the crossing" in text
    assert "noise-free episode on the map itself" in text
    train = build_parser().parse_args(["train", "--preset", "hardened", "--map-branch", "25", "--out", "y"])
    assert train.map_branch == 25.0


def test_the_published_branch_experiment_is_the_documented_command():
    from pathlib import Path

    from mahn_evo.experiment.plan import ExperimentPlan

    published = ExperimentPlan.load(Path(__file__).parents[2] / "docs" / "results" / "experiment_harden_branch")
    args = build_parser().parse_args(["experiment", "--modes", "situational", "--runs", "15", "--seed", "1",
                                      "--preset", "hardened", "--map-branch", "40", "--after-solved", "250"])
    assert experiment_plan(args) == published


def test_the_published_branch_plain_experiment_is_the_documented_command():
    from pathlib import Path

    from mahn_evo.experiment.plan import ExperimentPlan

    page = Path(__file__).parents[2] / "docs" / "results" / "experiment_harden_branch_plain"
    published = ExperimentPlan.load(page)
    args = build_parser().parse_args(["experiment", "--modes", "situational", "--runs", "15", "--seed", "1",
                                      "--preset", "hardened", "--map-branch", "40", "--plain-episodes", "1",
                                      "--after-solved", "250"])
    assert experiment_plan(args) == published
    assert "--plain-episodes 1" in (page / "README.md").read_text()
