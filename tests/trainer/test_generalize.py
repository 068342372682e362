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


def test_keyed_episodes_of_teams_that_share_robots_equal_each_team_played_alone():
    """Mirror readings share robots at the same places: keyed_episodes plays those once per key (robot episodes), and
    every team's episode is still its own, bit for bit."""
    import numpy as np

    from mahn_envs.core import BatchSim
    from mahn_envs.policies.team_controllers import TeamControllers
    from mahn_evo.evaluation.generalize import keyed_episodes
    from mahn_evo.evaluation.task_setup import task_params
    from mahn_evo.hyperneat.substrate import READINGS, team_reading
    from mahn_evo.hyperneat.team_evaluator import CONTROLLER_FIELDS

    rng = np.random.default_rng(2)
    painted = TeamControllers(*(rng.normal(0, 1.5, shape) for shape in ((4, 3, 2, 9, 7), (4, 3, 2, 9, 9),
                                                                         (4, 3, 2, 3, 9), (4, 3, 2, 9), (4, 3, 2, 3))))
    readings = [team_reading(painted, r) for r in READINGS]
    teams = TeamControllers(*(np.concatenate([getattr(t, f) for t in readings]) for f in CONTROLLER_FIELDS))
    params = task_params("generalization")
    keys = [3, 8, 21]
    fit, solved = keyed_episodes(teams, "plus", params, 5, keys)
    for t in range(teams.w_ih.shape[0]):
        for j, key in enumerate(keys):
            res = BatchSim("plus", 1, params).run_controllers(teams.team(t), seed=5, episode_keys=[key])
            assert fit[t, j] == res.fitness[0] and solved[t, j] == res.solved[0]
    assert len(np.unique(fit)) > 6
