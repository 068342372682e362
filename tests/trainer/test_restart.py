"""restart_every: fresh populations until the first solution; deterministic and resumable."""
from __future__ import annotations

import json

import numpy as np
import pytest

from mahn_evo.cli import build_parser, experiment_plan, main
from mahn_evo.training.config import EvolutionConfig
from mahn_evo.training.trainer import Trainer


def _cfg(generations: int = 7, **kw) -> EvolutionConfig:
    return EvolutionConfig(seed=3, generations=generations, init="minimal", restart_every=3, **kw).with_overrides(
        pop=24)


def _genome_dicts(t: Trainer) -> list:
    return [g.to_dict() for g in t.population.genomes]


def test_a_restart_brings_the_fresh_population_of_its_seed_and_keeps_the_count(tmp_path):
    tr = Trainer(_cfg(), tmp_path / "r")
    for _ in range(3):
        tr.step()
    bred = _genome_dicts(tr)
    tr.step()  # generation 3 starts from a fresh population
    assert tr.rows[-1][0] == 3 and tr.population.generation == 4
    fresh = Trainer(EvolutionConfig(seed=_cfg().restart_seed(3), init="minimal").with_overrides(pop=24),
                    tmp_path / "f")
    assert _genome_dicts(fresh) != bred
    # what generation 3 evaluated is the fresh population of seed restart_seed(3) (its first generation)
    fresh.step()
    assert tr.rows[-1][2:4] == fresh.rows[-1][2:4]
    assert _cfg().restart_seed(3) != _cfg().restart_seed(6) != _cfg().seed


def test_an_attempt_after_a_restart_evolves_as_a_fresh_run_from_the_same_population(tmp_path):
    """Restart attempts are alike in law to first attempts: nothing of the old population (species, threshold,
    stagnation clocks, generator) steers the search after a restart, only the generation count and the champion
    carry on (docs/results/experiment_best_restarts/)."""
    cfg = _cfg(generations=9)
    tr = Trainer(cfg, tmp_path / "r")
    for _ in range(9):
        tr.step()  # restarts at generations 3 and 6
    fresh = Trainer(EvolutionConfig(seed=cfg.restart_seed(3), init="minimal").with_overrides(pop=24), tmp_path / "f")
    for _ in range(3):
        fresh.step()
    # generation, evaluations and best-ever carry on; the population's own columns are the fresh run's
    # (best, mean fitness, solved, n_solved, species, threshold, complexity: all but the wall time)
    def own(row: list) -> list:
        return row[2:4] + row[5:10]

    assert [own(row) for row in tr.rows[3:6]] == [own(row) for row in fresh.rows[0:3]]
    assert tr.rows[3][7] != tr.rows[2][7] or tr.rows[3][8] != tr.rows[2][8] or tr.rows[3][2:4] != tr.rows[2][2:4]


def test_restarts_are_resumed_bit_identically_and_listed_in_the_summary(tmp_path):
    full = Trainer(_cfg(), tmp_path / "full")
    summary = full.run()
    assert summary["restarts"] == [3, 6]
    for stop in (3, 4):  # killed just before a restart, and just after one
        part = Trainer(_cfg(generations=stop), tmp_path / f"p{stop}")
        part.run()
        resumed = Trainer(_cfg(), tmp_path / f"p{stop}", resume=True)
        resumed.run()
        assert [r[:-1] for r in resumed.rows] == [r[:-1] for r in full.rows]


def test_no_restart_after_the_first_solution_and_settings_are_checked(tmp_path):
    cfg = _cfg()
    assert cfg.restart_due(3, None) and cfg.restart_due(6, None)
    assert not cfg.restart_due(0, None) and not cfg.restart_due(4, None) and not cfg.restart_due(6, 2)
    assert not EvolutionConfig().restart_due(300, None)  # 0 never restarts (the paper)
    with pytest.raises(ValueError, match="restart_every must be a non-negative integer"):
        EvolutionConfig(restart_every=-1)
    tr = Trainer(cfg, tmp_path / "s")
    tr.step()
    tr.first_solved = 0  # as if generation 0 had held a solution
    before = tr.population
    for _ in range(3):
        tr.step()
    assert tr.population is before


def test_the_cli_and_the_experiment_plan_carry_the_setting(tmp_path):
    out = tmp_path / "run"
    assert main(["train", "--generations", "4", "--pop", "12", "--restart-every", "2", "--out", str(out),
                 "--quiet"]) == 0
    assert json.loads((out / "config.json").read_text())["restart_every"] == 2
    assert json.loads((out / "summary.json").read_text())["restarts"] == [2]
    args = build_parser().parse_args(["experiment", "--preset", "iros2011-multistep", "--symmetry", "mirror",
                                      "--restart-every", "100", "--out", str(tmp_path / "e")])
    plan = experiment_plan(args)
    assert plan.train_config("situational", 1).restart_every == 100
    assert np.isfinite(plan.restart_every)


def test_the_published_restarts_experiment_is_the_documented_command():
    from pathlib import Path

    from mahn_evo.experiment.plan import ExperimentPlan

    published = ExperimentPlan.load(Path(__file__).parents[2] / "docs" / "results" / "experiment_best_restarts")
    args = build_parser().parse_args(["experiment", "--modes", "situational", "--runs", "15", "--seed", "1",
                                      "--generations", "1000", "--after-solved", "50", "--preset",
                                      "iros2011-multistep", "--symmetry", "best", "--restart-every", "150"])
    assert experiment_plan(args) == published


def test_the_best_restarts_preset_is_the_faithful_preset_with_mirror_readings_and_restarts():
    from mahn_evo.training.config import EvolutionConfig
    from mahn_evo.training.presets import apply_preset

    best = apply_preset(EvolutionConfig(seed=3), "best-restarts")
    faithful = apply_preset(EvolutionConfig(seed=3), "iros2011-multistep")
    assert (best.symmetry, best.restart_every) == ("best", 150)
    assert best.neat == faithful.neat
    assert best.with_overrides(symmetry=faithful.symmetry, restart_every=faithful.restart_every) == faithful
    # explicit flags still override the preset
    args = build_parser().parse_args(["experiment", "--preset", "best-restarts", "--restart-every", "100"])
    assert experiment_plan(args).restart_every == 100


def test_the_published_experiment_is_the_best_restarts_preset():
    """docs/results/experiment/ holds the 15 + 15 runs of the chosen configuration: its plan is the preset's."""
    from pathlib import Path

    from mahn_evo.experiment.plan import ExperimentPlan

    published = ExperimentPlan.load(Path(__file__).parents[2] / "docs" / "results" / "experiment")
    args = build_parser().parse_args(["experiment", "--modes", "situational", "standard", "--runs", "15",
                                      "--seed", "1", "--preset", "best-restarts"])
    assert experiment_plan(args) == published
    spelled_out = build_parser().parse_args(["experiment", "--modes", "situational", "standard", "--preset",
                                             "iros2011-multistep", "--symmetry", "best", "--restart-every", "150"])
    assert experiment_plan(spelled_out) == published
