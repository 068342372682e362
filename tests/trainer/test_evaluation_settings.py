"""The evaluator takes one settings record, and a run's configuration builds it from its own (flat) fields."""
from __future__ import annotations

import dataclasses

import pytest

from mahn_evo.hyperneat import EvaluationSettings, TeamEvaluator
from mahn_evo.training.config import EvolutionConfig
from mahn_evo.training.trainer import Trainer


def test_a_default_run_evaluates_with_the_default_settings():
    assert EvolutionConfig().evaluation == EvaluationSettings()


def test_a_run_hands_its_evaluation_fields_to_the_evaluator(tmp_path):
    cfg = EvolutionConfig(mode="standard", map="asymmetric_plus", seed=7, episodes=3, evaluate_modules=False,
                          decision="net_input", symmetry="best", noise_draws="per_generation", aggregate="quantile",
                          quantile=0.5, noise_free_episode=True, generations=1).with_noise("generalization")
    ev = cfg.evaluation
    assert {f.name: getattr(ev, f.name) for f in dataclasses.fields(ev)} == {
        "mode": "standard", "map": "asymmetric_plus", "task": cfg.task, "episodes": 3, "seed": 7,
        "evaluate_modules": False, "cppn_activation": "recursive", "decision": "net_input", "symmetry": "best",
        "noise_draws": "per_generation",
        "aggregate": "quantile", "quantile": 0.5, "noise_free_episode": True, "map_spread": 0.0,
        "map_branch": 0.0, "branch_sides": "both", "plain_episodes": 0, "sequential_episodes": 0,
        "sequential_plain": 0, "noise_free_variants": 0}
    trainer = Trainer(cfg.with_overrides(pop=8), tmp_path / "run")
    assert trainer.evaluator.settings == ev
    assert trainer.evaluator.world.name == "asymmetric_plus"


@pytest.mark.parametrize(("field", "bad", "error"), [
    ("mode", "heroic", ValueError), ("episodes", 0, ValueError), ("episodes", True, ValueError),
    ("aggregate", "median", ValueError), ("noise_draws", "often", ValueError), ("quantile", 1.5, ValueError),
    ("cppn_activation", "fast", ValueError), ("noise_free_episode", "yes", TypeError), ("seed", -1, ValueError),
    ("map_spread", 1.5, ValueError),
    ("map_branch", 60.0, ValueError), ("plain_episodes", -1, ValueError), ("sequential_episodes", -2, ValueError),
    ("sequential_episodes", True, ValueError),
])
def test_bad_evaluation_fields_are_refused_by_name_in_both_records(field, bad, error):
    with pytest.raises(error, match=field):
        EvaluationSettings(**{field: bad})
    with pytest.raises(error, match=field):
        EvolutionConfig(**{field: bad})


def test_the_evaluator_takes_the_settings_record_not_loose_arguments():
    with pytest.raises(TypeError, match="EvaluationSettings"):
        TeamEvaluator("situational")  # type: ignore[arg-type]
