"""`mahn-evo screen`: variants compared on the seeds finished in all of them, Fisher's test, survival plot."""
import json

import pytest

from mahn_evo.cli import main
from mahn_evo.experiment import ExperimentPlan, run_experiment
from mahn_evo.experiment.screen import screen_results

SMALL = dict(modes=("situational",), seed=5, generations=2, population=16, max_cycles=240, signal_tick=120,
             general_episodes=1, transfer_episodes=1, top=1, replays=0, after_solved=0)


def _experiment(folder, runs, **kw):
    run_experiment(ExperimentPlan(runs=runs, **SMALL, **kw), folder, workers=1, analyse=False, log=lambda m: None)


def test_screen_compares_common_seeds_and_writes_its_files(tmp_path):
    _experiment(tmp_path / "default", runs=2)
    _experiment(tmp_path / "relax", runs=1, cppn_activation="relax")
    out = tmp_path / "screen"
    assert main(["screen", str(tmp_path / "default"), str(tmp_path / "relax"), "--baseline", "default",
                 "--out", str(out)]) == 0
    res = json.loads((out / "screen.json").read_text())
    assert res["seeds"] == [5]  # seed 6 finished in one variant only: not compared
    assert res["variants"]["default"]["finished_seeds"] == [5, 6]
    relax = res["variants"]["relax"]
    assert relax["runs"] == 1 and relax["plan"]["cppn_activation"] == "relax"
    assert relax["fisher_p_vs_baseline"] == 1.0 and len(relax["survival"]) == 2
    assert res["variants"]["default"]["solved_all_finished"] == 0
    assert [r["seed"] for r in res["variants"]["default"]["finished_runs"]] == [5, 6]
    assert (out / "survival.png").stat().st_size > 1000 and "| relax | 0/1 |" in (out / "screen.md").read_text()


def test_screen_refuses_unequal_budgets_and_unknown_baselines(tmp_path):
    _experiment(tmp_path / "a", runs=1)
    run_experiment(ExperimentPlan(runs=1, **{**SMALL, "generations": 3}), tmp_path / "b", workers=1, analyse=False,
                   log=lambda m: None)
    with pytest.raises(ValueError, match="generation limits"):
        screen_results([tmp_path / "a", tmp_path / "b"], baseline="a")
    with pytest.raises(ValueError, match="baseline"):
        screen_results([tmp_path / "a"], baseline="c")
    # a common budget no larger than either limit compares them; a larger one is refused
    res = screen_results([tmp_path / "a", tmp_path / "b"], baseline="a", generations=2)
    assert res["generations"] == 2 and res["seeds"] == [5]
    assert [len(v["survival"]) for v in res["variants"].values()] == [2, 2]
    b = res["variants"]["b"]["finished_runs"][0]
    assert b["generations"] == 2  # read as if it had stopped at generation 2
    with pytest.raises(ValueError, match="common budget of 3"):
        screen_results([tmp_path / "a", tmp_path / "b"], baseline="a", generations=3)


def test_a_run_read_at_a_smaller_budget_counts_only_what_it_found_within_it():
    from pathlib import Path

    import numpy as np

    from mahn_evo.experiment.table import RunRecord

    best = np.array([1.0, 2.0, 50.0, 60.0, 161.0, 161.0])
    run = RunRecord(name="situational_s001", mode="situational", seed=1, folder=Path("."), finished=True,
                    generations=6, solved=True, first_solved=4, best_fitness=161.0, wall_seconds=1.0, best_ever=best)
    early = run.at_generation(4)
    assert (early.solved, early.first_solved, early.best_fitness, early.generations) == (False, None, 60.0, 4)
    assert run.at_generation(5).generations_to_solve == 5 and run.at_generation(5).solved
    assert run.at_generation(6) is run and run.at_generation(100) is run
    running = RunRecord(name="situational_s002", mode="situational", seed=2, folder=Path("."), finished=False,
                        generations=3, solved=False, first_solved=None, best_fitness=2.0, wall_seconds=1.0,
                        best_ever=best[:3])
    assert running.at_generation(2).finished and running.at_generation(3).finished
    assert not running.at_generation(4).finished


def test_experiment_cli_takes_presets_and_robust_options(tmp_path):
    out = tmp_path / "exp"
    assert main(["experiment", "--modes", "situational", "--runs", "1", "--seed", "5", "--generations", "1",
                 "--pop", "16", "--max-cycles", "240", "--signal-tick", "120", "--preset", "iros2011-code",
                 "--noise", "generalization", "--episodes", "2", "--noise-draws", "per_generation",
                 "--no-analysis", "--workers", "1", "--out", str(out)]) == 0
    plan = json.loads((out / "experiment.json").read_text())
    assert (plan["init"], plan["evaluate_modules"], plan["noise"], plan["episodes"]) == \
        ("iros2011", False, "generalization", 2)
    assert plan["neat"]["species_order"] == "random" and plan["neat"]["stagnation_rule"] == "sticky"
    cfg = json.loads((out / "runs" / "situational_s005" / "config.json").read_text())
    assert cfg["task"]["sensor_noise"] == 5.0 and cfg["noise_draws"] == "per_generation"
    assert plan["decision"] == cfg["decision"] == "output"
