"""Final validation (mahn_evo.evaluation.final_population): the final population scored on validation episodes."""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from mahn_evo.cli import main
from mahn_evo.evaluation.eval_champion import champion_policy
from mahn_evo.evaluation.final_population import (
    SEQUENTIAL_SEED,
    VALIDATION_KEY,
    final_population,
    validate_final_population,
)
from mahn_evo.evaluation.generalize import solutions_of
from mahn_evo.evaluation.protocols import sequential
from mahn_evo.evaluation.task_setup import task_params
from mahn_evo.hyperneat.substrate import team_reading
from mahn_evo.hyperneat.team_evaluator import TeamEvaluator
from mahn_evo.storage.files import atomic_write_checked_json, read_checked_json
from mahn_evo.training.champion import Champion

CHAMPION = Path(__file__).parents[2] / "docs" / "results" / "experiment" / "champions" / "situational_s012.json"


def _tiny_run(tmp_path: Path, name: str = "run") -> Path:
    out = tmp_path / name
    assert main(["train", "--preset", "best-restarts", "--generations", "1", "--pop", "12", "--seed", "5",
                 "--quiet", "--out", str(out)]) == 0
    return out


def _plant(run: Path, champion: Path, index: int) -> None:
    """Put a published solution's CPPN into the run's final population at `index` (a real genome, decoded and
    played like any other)."""
    ckpt = run / "checkpoint.json"
    data = read_checked_json(ckpt, "checkpoint")
    data["population"]["genomes"][index] = json.loads(champion.read_text())["cppn"]
    atomic_write_checked_json(ckpt, "checkpoint", {k: v for k, v in data.items() if k not in ("kind", "version")})


def test_a_population_without_solutions_archives_nothing_and_says_so(tmp_path, capsys):
    run = _tiny_run(tmp_path)
    before = sorted(p.name for p in (run / "archive").glob("*")) if (run / "archive").exists() else []
    record = validate_final_population(run, episodes=2)
    assert record["chosen"] is None and record["teams"] == 3 * 12  # every reading of every team (symmetry best)
    assert record["first_key"] == VALIDATION_KEY and record["episodes"] == 2
    assert (sorted(p.name for p in (run / "archive").glob("*")) if (run / "archive").exists() else []) == before
    saved = json.loads((run / "final_validation.json").read_text())
    assert saved["kind"] == "final_validation" and saved["chosen"] is None
    assert main(["final-validation", str(run), "--episodes", "2"]) == 0
    assert "nothing archived" in capsys.readouterr().out


def test_the_best_noise_free_solution_of_the_population_is_archived(tmp_path):
    run = _tiny_run(tmp_path)
    _plant(run, CHAMPION, 7)
    record = validate_final_population(run, episodes=3)
    chosen = record["chosen"]
    assert chosen is not None and chosen["index"] == 7 and chosen["noise_free_solved"]
    assert chosen["solved_fraction"] == max(r["solved_fraction"] for r in record["top"] if r["noise_free_solved"])
    path = run / chosen["file"]
    assert path.name.startswith("solution_final_g") and path in solutions_of(run)
    champ = Champion.load(path)  # a valid champion file: its controllers are what its CPPN decodes to
    config, population = final_population(run)
    decoded = team_reading(TeamEvaluator(config.evaluation).decode([population.genomes[7]]), chosen["reading"])
    assert np.array_equal(champ.controllers.w_ih, decoded.w_ih[0])
    assert champ.solved and champ.generation == population.generation == 1
    # deterministic: the same record again
    assert validate_final_population(run, episodes=3, write=False) == record


def test_bad_input_is_a_clear_error(tmp_path):
    with pytest.raises(ValueError, match="no checkpoint.json"):
        validate_final_population(tmp_path)
    run = _tiny_run(tmp_path)
    with pytest.raises(ValueError, match="episodes must be a positive integer"):
        validate_final_population(run, episodes=0)
    (run / "checkpoint.json").write_text((run / "checkpoint.json").read_text()[:-40])
    with pytest.raises(ValueError, match="checkpoint"):
        validate_final_population(run)
    assert main(["final-validation", str(run)]) == 2


ROBUST = Path(__file__).parents[2] / "docs" / "results" / "experiment_fresh_seeds_lifetime" / "champions" / \
    "situational_s029.json"


def test_the_sequential_stage_chooses_the_team_that_survives_the_real_world_protocol(tmp_path, capsys):
    """Two published solutions planted in a final population: s012 (faithful; 0-3 of 10 noisy sequential episodes
    in the published transfer test) and a lifetime-hardened s029 (10 of 10).  Every reading of both that solves
    the noise-free task played through 4 noisy sequential episodes, the stage must rank them by successes, archive
    the winner, and say so in the record."""
    run = _tiny_run(tmp_path)
    _plant(run, CHAMPION, 2)
    _plant(run, ROBUST, 7)
    plain = validate_final_population(run, episodes=3, write=False)
    solutions = [(r["index"], r["reading"]) for r in plain["top"] if r["noise_free_solved"]]
    assert {i for i, _ in solutions} == {2, 7}
    record = validate_final_population(run, episodes=3, sequential_teams=len(solutions), sequential_episodes=4)
    seq = record["sequential"]
    assert (seq["teams"], seq["episodes"], seq["first_seed"], seq["map"]) == (len(solutions), 4, SEQUENTIAL_SEED,
                                                                              "plus")
    ranking = seq["ranking"]
    # the candidates are the plain ranking's noise-free solutions, now ordered by sequential successes
    assert sorted((r["index"], r["reading"]) for r in ranking) == sorted(solutions)
    assert [r["sequential_successes"] for r in ranking] == sorted((r["sequential_successes"] for r in ranking),
                                                                  reverse=True)
    chosen = record["chosen"]
    assert chosen["index"] == 7 and chosen == {**ranking[0], "file": chosen["file"]}
    assert chosen["sequential_successes"] > max(r["sequential_successes"] for r in ranking if r["index"] == 2)
    # the archived file plays the same: its sequential episodes replayed from the file give the recorded count
    champ = Champion.load(run / chosen["file"])
    again = sequential(champion_policy(champ), map="plus", params=champ.task(task_params("generalization")),
                       episodes=4, seed=SEQUENTIAL_SEED)
    assert sum(again["solved"]) == chosen["sequential_successes"]
    saved = json.loads((run / "final_validation.json").read_text())
    assert saved["chosen"]["file"] == chosen["file"] and saved["sequential"]["ranking"][0]["index"] == 7
    assert main(["final-validation", str(run), "--episodes", "3", "--sequential", str(len(solutions)),
                 "--sequential-episodes", "4"]) == 0
    assert f"{chosen['sequential_successes']} of 4 sequential episodes" in capsys.readouterr().out
    with pytest.raises(ValueError, match="sequential_teams must be a non-negative integer"):
        validate_final_population(run, sequential_teams=-1)
    with pytest.raises(ValueError, match="sequential_episodes must be a positive integer"):
        validate_final_population(run, sequential_teams=1, sequential_episodes=0)
