"""Noise parts: the task taken apart level by level, each part's episodes equal to a plain evaluation, and the CLI."""
import json
from dataclasses import replace
from pathlib import Path

import pytest

from mahn_envs.core.params import NOISE_FIELDS, TaskParams
from mahn_evo.cli import main
from mahn_evo.evaluation.eval_champion import evaluate_champion
from mahn_evo.evaluation.noise_parts import noise_part_params, noise_parts
from mahn_evo.evaluation.task_setup import task_params

FIXTURES = Path(__file__).resolve().parent / "fixtures"
SENSOR_BREAKS = FIXTURES / "first_solution_fails_plus_under_sensor_noise.json"


def test_each_part_keeps_one_level_of_the_preset():
    full = task_params("generalization")
    parts = noise_part_params(full)
    assert list(parts) == ["all", "none"] + [f"{n} only" for n in NOISE_FIELDS]
    assert parts["all"] == full
    assert all(getattr(parts["none"], n) == 0.0 for n in NOISE_FIELDS)
    for name in NOISE_FIELDS:
        part = parts[f"{name} only"]
        assert {n for n in NOISE_FIELDS if getattr(part, n) > 0} == {name}
        assert getattr(part, name) == getattr(full, name)
        assert part.max_cycles == full.max_cycles and part.reflex == full.reflex  # only the noise changes


def test_levels_at_zero_are_no_part_and_no_noise_is_an_error():
    parts = noise_part_params(replace(TaskParams(), sensor_noise=5.0))
    assert list(parts) == ["all", "none", "sensor_noise only"]
    with pytest.raises(ValueError, match="noise parts need a task with noise"):
        noise_part_params(TaskParams())
    with pytest.raises(ValueError, match="unknown noise level"):
        TaskParams().only_noise("wind")


def test_a_part_plays_the_same_episodes_as_a_plain_evaluation():
    full = task_params("generalization")
    rows = {r["noise"]: r for r in noise_parts(SENSOR_BREAKS, full, episodes=3, seed=4)}
    for name, params in (("all", full), ("none", full.without_noise()),
                         ("heading_noise only", full.only_noise("heading_noise"))):
        plain = evaluate_champion(SENSOR_BREAKS, episodes=3, params=params, seed=4)
        assert rows[name]["fitness"] == plain["fitness"]
        assert rows[name]["solved_fraction"] == plain["solved_fraction"]


def test_the_sensor_noise_alone_breaks_this_team_on_the_real_world_protocol(capsys):
    assert main(["eval", str(SENSOR_BREAKS), "--sensor-noise", "5", "--noise-parts", "--protocol", "sequential",
                 "--episodes", "2", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    parts = {r["noise"]: r for r in out["parts"]}
    assert list(parts) == ["all", "none", "sensor_noise only"] and out["episodes"] == 2
    assert parts["none"]["success_fraction"] == 1.0
    assert parts["sensor_noise only"]["success_fraction"] == 0.0


def test_the_cli_names_what_cannot_be_done(capsys):
    assert main(["eval", str(SENSOR_BREAKS), "--noise-parts"]) == 2
    assert "noise parts need a task with noise" in capsys.readouterr().err
    assert main(["eval", str(SENSOR_BREAKS), "--noise", "generalization", "--noise-parts", "--margins"]) == 2
    assert "does not combine" in capsys.readouterr().err
    assert main(["eval", str(SENSOR_BREAKS), "--noise", "generalization", "--noise-parts", "--episodes", "0"]) == 2
    assert "episodes must be a positive integer" in capsys.readouterr().err
