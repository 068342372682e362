"""Final validation (mahn_evo.evaluation.final_population): the final population scored on validation episodes."""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from mahn_evo.cli import main
from mahn_evo.evaluation.final_population import VALIDATION_KEY, final_population, validate_final_population
from mahn_evo.evaluation.generalize import solutions_of
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
