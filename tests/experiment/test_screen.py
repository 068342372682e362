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
