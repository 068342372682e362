"""The generalisation test ranks every archived solution under keyed noise."""
import json

import pytest

from mahn_evo.cli import main
from mahn_evo.evaluation.generalize import generalize
from mahn_evo.training.config import EvolutionConfig
from mahn_evo.training.trainer import train


def test_ranks_archived_solutions(tmp_path):
    train(EvolutionConfig(generations=3, seed=2).with_overrides(pop=24), tmp_path)
    (tmp_path / "archive").mkdir()
    champ = json.loads((tmp_path / "champion.json").read_text())
    for g in (1, 2):  # two archived "solutions": the champion and a copy with zeroed output biases
        champ["generation"] = g
        if g == 2:
            champ["controllers"]["b_o"] = [[[0.0] * 3 for _ in b] for b in champ["controllers"]["b_o"]]
        (tmp_path / "archive" / f"solution_g{g:05d}_i0000.json").write_text(json.dumps(champ))
    rows = generalize(tmp_path, episodes=6)
    assert [r["rank"] for r in rows] == [1, 2]
    assert rows[0]["mean_fitness"] >= rows[1]["mean_fitness"] or rows[0]["solved_fraction"] > rows[1]["solved_fraction"]
    assert rows[0]["std_fitness"] > 0  # noise makes episodes differ
    again = generalize(tmp_path, episodes=6, write=False)
    assert again == rows  # common random numbers: deterministic
    assert (tmp_path / "generalization.csv").exists()
    assert main(["generalize", str(tmp_path), "--episodes", "3", "--json"]) == 0


def test_missing_run_folder(tmp_path):
    with pytest.raises(ValueError, match="does not exist"):
        generalize(tmp_path / "nope")
