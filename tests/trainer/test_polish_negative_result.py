"""docs/results/polish/polish.py, the negative result's search: a short polish keeps a team no worse than the
original on its validation episodes, writes a champion file whose controllers are what its CPPN decodes to, and
gives the same result for the same seed."""
from __future__ import annotations

import importlib.util
import json
import sys
from pathlib import Path

import numpy as np

from mahn_evo.training.champion import Champion

ROOT = Path(__file__).resolve().parents[2]
PICK = ROOT / "docs" / "results" / "experiment_hardened_sequential" / "champions" / "situational_s013.json"


def _polish_module():
    spec = importlib.util.spec_from_file_location("polish", ROOT / "docs" / "results" / "polish" / "polish.py")
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # its dataclasses look their module up
    spec.loader.exec_module(module)
    return module


def test_a_short_polish_keeps_a_team_no_worse_and_repeats(tmp_path):
    polish = _polish_module()
    settings = polish.PolishSettings(generations=2, popsize=4, sigma=3e-4, episodes=1, plain_episodes=1,
                                     sequential_episodes=1, sequential_plain=1, validation=1)
    first = polish.polish(Champion.load(PICK), settings)
    assert first.polished >= first.original
    assert [f["name"] for f in first.finalists] == ["original", "best of generation 0", "best of generation 1",
                                                    "mean"]
    assert first.polished == max(f["validation"] for f in first.finalists)
    again = polish.polish(Champion.load(PICK), settings)
    assert again.log[-1][:5] == first.log[-1][:5] and again.chosen == first.chosen
    assert np.array_equal(again.champion.genome.weight, first.champion.genome.weight)
    first.champion.save(tmp_path / "kept.json")
    kept = Champion.load(tmp_path / "kept.json")  # refuses controllers its CPPN does not decode to
    assert kept.solved == first.champion.solved


def test_polish_settings_name_their_bad_values():
    polish = _polish_module()
    for bad, match in (({"popsize": 1}, "popsize"), ({"sigma": 0}, "sigma"), ({"noise": "loud"}, "noise"),
                       ({"generations": 0}, "generations")):
        try:
            polish.PolishSettings(**bad)
        except ValueError as exc:
            assert match in str(exc)
        else:
            raise AssertionError(f"{bad} was accepted")


def test_the_published_summaries_say_what_the_page_says():
    summary = json.loads((ROOT / "docs" / "results" / "polish" / "s013" / "summary.json").read_text())
    page = (ROOT / "docs" / "results" / "polish" / "README.md").read_text()
    assert f"{summary['original_validation']:.2f} -> {summary['polished_validation']:.2f}" in page
