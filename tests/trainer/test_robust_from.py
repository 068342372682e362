"""robust_from "first_solution": the noise-free run until its first solution, robust evaluation after it."""
from __future__ import annotations

import json
from dataclasses import replace

import numpy as np
import pytest

from mahn_evo.cli import main
from mahn_evo.experiment.plan import ExperimentPlan
from mahn_evo.hyperneat.team_evaluator import TeamEvaluator
from mahn_evo.training.config import EvolutionConfig
from mahn_evo.training.trainer import Trainer

SOLVED_AT = 1  # the generation the tests declare solved (a real solution takes hundreds of generations)


def _hardening(robust_delay: int = 0, **kw) -> EvolutionConfig:
    base = dict(generations=6, seed=7, episodes=2, noise_draws="per_generation", noise_free_episode=True)
    base.update(kw)
    cfg = EvolutionConfig(**base).with_overrides(pop=24).with_noise("generalization")
    return cfg.with_overrides(robust_from="first_solution", robust_delay=robust_delay)


def _noise_free() -> EvolutionConfig:
    return EvolutionConfig(generations=6, seed=7).with_overrides(pop=24)


def _rows(t: Trainer) -> list[list]:
    return [r[:-1] for r in t.rows]  # without the seconds column


def _declare_solved(t: Trainer) -> None:
    """As if generation SOLVED_AT had held a solution (the state the trainer keeps when one is found)."""
    while t.generation <= SOLVED_AT:
        t.step()
    t.first_solved = SOLVED_AT


def test_before_the_first_solution_the_run_is_the_noise_free_run(tmp_path):
    hard, clean = Trainer(_hardening(), tmp_path / "h"), Trainer(_noise_free(), tmp_path / "c")
    for _ in range(3):
        hard.step()
        clean.step()
    assert _rows(hard) == _rows(clean)
    assert hard.noise_free_evaluator is not None
    assert hard.noise_free_evaluator.settings == clean.evaluator.settings


def test_after_the_first_solution_teams_are_scored_under_noise(tmp_path):
    cfg = _hardening()
    hard = Trainer(cfg, tmp_path / "h")
    _declare_solved(hard)
    genomes = hard.population.ask()  # the next generation, as step() will ask for it
    expected = TeamEvaluator(cfg.evaluation).evaluate(genomes, SOLVED_AT + 1).fitness
    hard.step()
    row = hard.rows[-1]
    assert row[0] == SOLVED_AT + 1
    assert row[2] == pytest.approx(float(expected.max()), abs=0)  # best fitness: the robust evaluation's
    assert row[1] - hard.rows[-2][1] == 24 * cfg.episodes  # evaluations count the noisy episodes
    # the champion is the robust phase's best, even where a noise-free score was higher
    champ = json.loads((tmp_path / "h" / "champion.json").read_text())
    assert champ["generation"] == SOLVED_AT + 1 and champ["fitness"] == float(expected.max())
    assert hard.best_fitness == float(expected.max())
    summary = hard.finish()
    assert summary["robust_from_generation"] == SOLVED_AT + 1 and summary["first_solved_generation"] == SOLVED_AT


def test_the_switch_resumes_bit_identically(tmp_path):
    full = Trainer(_hardening(), tmp_path / "full")
    _declare_solved(full)
    while full.generation < 5:
        full.step()
    full.finish()
    part = Trainer(_hardening(), tmp_path / "part")
    _declare_solved(part)
    part.step()  # the first robust generation, then an interruption
    part.finish()
    resumed = Trainer(_hardening(), tmp_path / "part", resume=True)
    assert resumed.first_solved == SOLVED_AT
    while resumed.generation < 5:
        resumed.step()
    assert _rows(resumed) == _rows(full)
    assert np.isclose(resumed.best_fitness, full.best_fitness, rtol=0, atol=0)


def test_robust_from_needs_noise_and_a_known_value():
    with pytest.raises(ValueError, match="no noise"):
        EvolutionConfig(robust_from="first_solution")
    with pytest.raises(ValueError, match="robust_from"):
        replace(_hardening(), robust_from="later")
    cfg = _hardening()
    assert EvolutionConfig.from_mapping(cfg.to_dict()) == cfg
    assert EvolutionConfig.from_saved({k: v for k, v in EvolutionConfig().to_dict().items()
                                       if k != "robust_from"}).robust_from == "start"  # older files


def test_experiment_plan_and_cli_pass_it_to_every_run(tmp_path):
    plan = ExperimentPlan(modes=("situational",), runs=1, noise="generalization", episodes=2,
                          noise_draws="per_generation", robust_from="first_solution", robust_delay=30)
    cfg = plan.train_config("situational", 1)
    assert (cfg.robust_from, cfg.robust_delay, cfg.episodes) == ("first_solution", 30, 2) and cfg.task.sensor_noise > 0
    assert ExperimentPlan.from_mapping({k: v for k, v in plan.to_dict().items()
                                        if k not in ("robust_from", "robust_delay")}).robust_from \
        == "start"
    out = tmp_path / "run"
    assert main(["train", "--generations", "1", "--pop", "12", "--noise", "generalization", "--episodes", "2",
                 "--robust-from", "first_solution", "--robust-delay", "7", "--out", str(out), "--quiet"]) == 0
    saved = json.loads((out / "config.json").read_text())
    assert (saved["robust_from"], saved["robust_delay"]) == ("first_solution", 7)
    assert json.loads((out / "summary.json").read_text())["robust_from_generation"] is None  # not solved


def test_robust_delay_keeps_the_run_noise_free_for_that_many_generations_after_the_solution(tmp_path):
    delayed = Trainer(_hardening(robust_delay=2), tmp_path / "d")
    clean = Trainer(_noise_free(), tmp_path / "c")
    _declare_solved(delayed)
    _declare_solved(clean)
    for _ in range(2):  # generations SOLVED_AT + 1 and + 2: still the noise-free run
        delayed.step()
        clean.step()
    assert _rows(delayed) == _rows(clean)
    delayed.step()  # SOLVED_AT + 3: the first robust generation
    assert delayed.rows[-1][1] - delayed.rows[-2][1] == 24 * 2
    assert delayed.finish()["robust_from_generation"] == SOLVED_AT + 3
    with pytest.raises(ValueError, match="robust_delay"):
        _hardening(robust_delay=-1)
    with pytest.raises(ValueError, match="first_solution"):
        EvolutionConfig(robust_delay=5)


def test_the_hardened_preset_is_the_faithful_preset_with_a_robust_phase():
    from mahn_evo.training.presets import apply_preset

    hard = apply_preset(EvolutionConfig(seed=4), "hardened")
    faithful = apply_preset(EvolutionConfig(seed=4), "iros2011-multistep")
    assert (hard.robust_from, hard.robust_delay, hard.episodes, hard.noise_draws, hard.noise_free_episode) == \
        ("first_solution", 50, 3, "per_generation", True)
    assert hard.noise_preset == "generalization" and faithful.noise_preset == "none"
    assert hard.noise_free_evaluation == faithful.evaluation  # until the robust phase, the faithful run
    assert hard.neat == faithful.neat
    with pytest.raises(ValueError, match="before its robust phase"):
        hard.with_overrides(stop_when_solved=True, after_solved=50)
    assert hard.with_overrides(stop_when_solved=True, after_solved=51).after_solved == 51
    # a preset without noise leaves a configuration's robust phase alone
    kept = apply_preset(_hardening(robust_delay=3), "iros2011-multistep")
    assert (kept.robust_from, kept.robust_delay, kept.noise_preset) == ("first_solution", 3, "generalization")


def test_the_hardened_preset_reproduces_the_published_hardening_experiment():
    from pathlib import Path

    from mahn_evo.cli import build_parser, experiment_plan

    published = ExperimentPlan.load(Path(__file__).parents[2] / "docs" / "results" / "experiment_harden")
    args = build_parser().parse_args(["experiment", "--modes", "situational", "standard", "--preset", "hardened",
                                      "--after-solved", "250"])
    assert experiment_plan(args) == published
    spelled_out = build_parser().parse_args([
        "experiment", "--modes", "situational", "standard", "--preset", "iros2011-multistep", "--noise",
        "generalization",
        "--episodes", "3", "--noise-draws", "per_generation", "--noise-free-episode", "--aggregate", "mean",
        "--robust-from", "first_solution", "--robust-delay", "50", "--after-solved", "250"])
    assert experiment_plan(spelled_out) == published
    with pytest.raises(ValueError, match="before its robust phase"):
        experiment_plan(build_parser().parse_args(["experiment", "--preset", "hardened"]))


def _noise_free_until(generation: int, folder) -> None:
    """The noise-free run, solved at SOLVED_AT and stopped (checkpointed) before generation `generation`."""
    clean = Trainer(_noise_free(), folder)
    _declare_solved(clean)
    while clean.generation < generation:
        clean.step()
    clean.finish()


def test_a_solved_run_resumed_with_a_robust_phase_it_has_not_reached_is_the_hardened_run(tmp_path):
    delay = 2
    fresh = Trainer(_hardening(robust_delay=delay), tmp_path / "fresh")
    _declare_solved(fresh)
    while fresh.generation < 6:
        fresh.step()
    start = SOLVED_AT + delay + 1
    _noise_free_until(start, tmp_path / "later")  # stopped just before the robust phase would start
    later = Trainer(_hardening(robust_delay=delay), tmp_path / "later", resume=True)
    assert later.first_solved == SOLVED_AT and later.generation == start
    while later.generation < 6:
        later.step()
    assert _rows(later) == _rows(fresh)
    assert later.rows[start][1] - later.rows[start - 1][1] == 24 * 2  # noisy episodes from the phase's start
    assert later.finish()["robust_from_generation"] == start
    saved = json.loads((tmp_path / "later" / "config.json").read_text())
    assert (saved["robust_from"], saved["robust_delay"], saved["episodes"]) == ("first_solution", delay, 2)


def test_a_robust_phase_is_refused_when_the_run_went_past_its_start(tmp_path):
    _noise_free_until(SOLVED_AT + 3, tmp_path / "run")  # scored generation SOLVED_AT + 2 without noise
    with pytest.raises(ValueError, match="robust phase starting at generation 3"):
        Trainer(_hardening(robust_delay=1), tmp_path / "run", resume=True)
    # anything else that changes how teams are scored is still refused
    with pytest.raises(ValueError, match="differs in"):
        Trainer(replace(_hardening(robust_delay=5), symmetry="best"), tmp_path / "run", resume=True)
    with pytest.raises(ValueError, match="differs in"):
        Trainer(replace(_noise_free(), episodes=2), tmp_path / "run", resume=True)
    assert Trainer(_hardening(robust_delay=2), tmp_path / "run", resume=True).generation == SOLVED_AT + 3


def test_an_experiment_may_harden_its_runs_when_they_stopped_before_the_robust_phase(tmp_path):
    clean = ExperimentPlan(modes=("situational",), runs=2, after_solved=50)
    clean.save_or_check(tmp_path)
    hard = replace(clean, noise="generalization", episodes=3, noise_draws="per_generation", noise_free_episode=True,
                   robust_from="first_solution", robust_delay=50, after_solved=250)
    assert hard.hardens(clean)
    with pytest.raises(ValueError, match="different plan"):
        replace(hard, robust_delay=49).save_or_check(tmp_path)  # the runs scored generation solved + 50 noise-free
    with pytest.raises(ValueError, match="different plan"):
        replace(hard, symmetry="best").save_or_check(tmp_path)
    hard.save_or_check(tmp_path)
    assert ExperimentPlan.load(tmp_path) == hard
