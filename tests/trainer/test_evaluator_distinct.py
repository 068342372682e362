"""The evaluator runs each distinct team once and gives duplicates the same scores."""
import numpy as np

from mahn_envs.core import TaskParams
from mahn_envs.policies.team_controllers import TeamControllers
from mahn_evo.hyperneat.team_evaluator import CONTROLLER_FIELDS, EvaluationSettings, TeamEvaluator, distinct_teams
from tests.envs.helpers import random_team


def _batch(teams) -> TeamControllers:
    return TeamControllers(*(np.stack([getattr(t, f) for t in teams]).astype(np.float32) for f in CONTROLLER_FIELDS))


def test_distinct_teams_groups_bit_identical_controllers_in_order_of_appearance():
    teams = [random_team(s) for s in (3, 1, 3, 2, 1, 3)]
    signed = random_team(2)
    signed.b_o[0, 0, 0] = -0.0  # a different bit pattern: kept apart, though -0.0 == 0.0
    teams[3].b_o[0, 0, 0] = 0.0
    first, index = distinct_teams(_batch(teams + [signed]))
    assert first.tolist() == [0, 1, 3, 6]
    assert index.tolist() == [0, 1, 0, 2, 1, 0, 3]


def test_score_runs_each_distinct_team_once_and_matches_scoring_them_apart():
    params = TaskParams(max_cycles=300, signal_tick=150, sensor_noise=5.0, start_jitter_xy=2.0)
    teams = [random_team(s) for s in (4, 5, 4, 6, 5, 4)]
    ev = TeamEvaluator(EvaluationSettings(task=params, episodes=2, seed=3))
    fit, solved = ev.score(_batch(teams))
    assert list(ev._sims) == [3]  # the episodes ran for the 3 distinct teams only
    alone = TeamEvaluator(EvaluationSettings(task=params, episodes=2, seed=3))
    for i, t in enumerate(teams):
        f, s = alone.score(_batch([t]))
        assert fit[i] == f[0] and solved[i] == s[0]
    assert fit[0] == fit[2] == fit[5] and fit[0] != fit[1]
