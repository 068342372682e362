"""Noise-free episodes on plus variants in evolution (EvaluationSettings.noise_free_variants): the turn where one
side arm opens alone rewarded without the noise's luck."""
from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from mahn_envs.core import BatchSim
from mahn_envs.maps.variants import spread_variant
from mahn_envs.policies.team_controllers import TeamControllers
from mahn_evo.cli import build_parser, experiment_plan
from mahn_evo.experiment.report import _robust_text
from mahn_evo.hyperneat.evaluation_settings import EvaluationSettings
from mahn_evo.hyperneat.team_evaluator import CLEAN_VARIANT_KEY, TeamEvaluator
from mahn_evo.training.champion import Champion
from mahn_evo.training.config import EvolutionConfig, continues_before_robust_phase

SEQ1 = Path(__file__).parents[2] / "docs" / "results" / "experiment_sequential_seeds_1_15" / "champions"
NOISY = EvolutionConfig().with_noise("generalization").task


def _teams(*champions: Champion) -> TeamControllers:
    return TeamControllers(*(np.stack([getattr(c.controllers, f) for c in champions])
                             for f in ("w_ih", "w_hh", "w_ho", "b_h", "b_o")))


def test_noise_free_variant_episodes_are_the_keys_variants_without_noise():
    """seq1's seed 15 pick (turns where one side opens alone) and seed 3's (does not), one noisy episode on a
    one-sided variant and two noise-free variant episodes: each noise-free score is the batch core's noise-free
    episode on the key's variant; keys are fresh per generation and shared by the teams."""
    turner, straight = Champion.load(SEQ1 / "situational_s015.json"), Champion.load(SEQ1 / "situational_s003.json")
    settings = EvaluationSettings(task=NOISY, episodes=1, noise_draws="per_generation", map_branch=49.0,
                                  branch_sides="one_short", noise_free_variants=2, seed=3)
    ev = TeamEvaluator(settings)
    assert ev.clean_variant_keys(0) == [CLEAN_VARIANT_KEY, CLEAN_VARIANT_KEY + 1]
    assert ev.clean_variant_keys(5) == [CLEAN_VARIANT_KEY + 10, CLEAN_VARIANT_KEY + 11]
    teams = _teams(turner, straight)
    fitness, solved, _ = ev.outcomes(teams, generation=5)
    plain, plain_solved, _ = TeamEvaluator(replace(settings, noise_free_variants=0)).outcomes(teams, generation=5)
    clean = np.zeros((2, 2))
    clean_solved = np.zeros((2, 2))
    for e, key in enumerate(ev.clean_variant_keys(5)):
        res = BatchSim(spread_variant(3, key, 0.0, 49.0, "one_short"), 2, NOISY.without_noise()).run_controllers(
            teams, seed=3, episode_keys=np.full(2, key, dtype=np.int64))
        clean[e], clean_solved[e] = res.fitness, res.solved
    assert np.allclose(fitness, (plain + clean.sum(axis=0)) / 3, atol=1e-9)
    assert np.allclose(solved, (plain_solved + clean_solved.sum(axis=0)) / 3)
    # noise-free, the turner solves the one-sided variants and the other team does not
    assert clean_solved[:, 0].all() and not clean_solved[:, 1].any()
    assert clean[:, 0].min() > 100 > 10 > clean[:, 1].max()
    # without them nothing changes: the scores of an evaluator that never knew of them
    assert np.array_equal(plain, TeamEvaluator(EvaluationSettings(
        task=NOISY, episodes=1, noise_draws="per_generation", map_branch=49.0, branch_sides="one_short",
        seed=3)).outcomes(teams, generation=5)[0])


def test_noise_free_variants_need_variants_and_a_count():
    with pytest.raises(ValueError, match="needs map_spread or map_branch"):
        EvaluationSettings(noise_free_variants=1)
    with pytest.raises(ValueError, match="noise_free_variants must be a non-negative integer"):
        EvaluationSettings(map_branch=40.0, noise_free_variants=-1)
    with pytest.raises(ValueError, match="noise_free_variants must be a non-negative integer"):
        EvaluationSettings(map_branch=40.0, noise_free_variants=True)


def test_a_robust_phase_with_noise_free_variants_hardens_a_saved_noise_free_run():
    """The option belongs to the robust phase: a run solved without it is resumed into a phase with it (the
    noise-free phase is unchanged), and the CLI, the experiment plan and the report carry it."""
    parser = build_parser()
    saved = experiment_plan(parser.parse_args(
        "experiment --out x --runs 2 --seed 1 --preset best-restarts".split()))
    harden = experiment_plan(parser.parse_args(
        "experiment --out x --runs 2 --seed 1 --preset best-restarts --noise generalization --episodes 3 "
        "--noise-draws per_generation --noise-free-episode --map-branch 49 --branch-sides one_short "
        "--plain-episodes 1 --noise-free-variants 1 --sequential-episodes 1 --robust-from first_solution "
        "--robust-delay 50 --after-solved 150 --fitness-memory lifetime".split()))
    assert harden.noise_free_variants == 1
    config = harden.train_config("situational", 1)
    assert config.noise_free_variants == 1 and config.evaluation.noise_free_variants == 1
    assert config.noise_free_evaluation.noise_free_variants == 0
    assert continues_before_robust_phase(saved.train_config("situational", 1), config) and harden.hardens(saved)
    text = _robust_text(harden.to_dict())
    assert "1 noise-free episode(s) on plus variants (`--noise-free-variants 1`)" in text
    assert "1 episode(s) of the sequential protocol (`--sequential-episodes 1`)" in text
    train = parser.parse_args(["train", "--noise-free-variants", "2", "--map-branch", "40", "--out", "y"])
    assert train.noise_free_variants == 2
