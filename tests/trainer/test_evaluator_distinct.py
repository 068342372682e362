"""The evaluator runs each distinct team once and gives duplicates the same scores."""
from dataclasses import replace

import numpy as np

from mahn_envs.core import TaskParams
from mahn_envs.policies.team_controllers import TeamControllers
from mahn_evo.hyperneat.evaluation_settings import EvaluationSettings
from mahn_evo.hyperneat.team_evaluator import CONTROLLER_FIELDS, TeamEvaluator, distinct_teams
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


def test_a_generation_memo_remembers_only_the_last_generation():
    from mahn_evo.hyperneat.memo import GenerationMemo

    memo: GenerationMemo[int] = GenerationMemo()
    memo.put("a", 1)
    memo.next_generation()
    memo.put("b", 2)
    assert memo.get("a") == 1  # used again in this generation: kept for the next
    memo.next_generation()
    assert memo.get("a") == 1 and memo.get("b") == 2
    memo.next_generation()
    memo.next_generation()
    assert memo.get("a") is None and len(memo) == 0


def test_memos_give_the_results_of_a_fresh_evaluator_and_skip_known_work(tmp_path):
    """Robust settings (fresh noisy draws each generation plus the noise-free episode) over generations whose
    genomes repeat (elites, duplicates): the memoised evaluator plays the noise-free episode only for teams it has
    not seen, and its controllers and scores equal those of a fresh evaluator bit for bit."""
    from mahn_evo.training.config import EvolutionConfig
    from mahn_evo.training.trainer import Trainer

    params = TaskParams(max_cycles=240, signal_tick=120, sensor_noise=5.0, start_jitter_xy=2.0)
    cfg = EvolutionConfig(episodes=2, noise_draws="per_generation", noise_free_episode=True, seed=4, task=params,
                          cppn_activation="relax", generations=4).with_overrides(pop=30)
    tr = Trainer(cfg, tmp_path / "run")
    skipped = []
    for gen in range(4):
        genomes = tr.population.ask()
        ev = tr.evaluator.evaluate(genomes, gen)
        fresh = TeamEvaluator(cfg.evaluation).evaluate(genomes, gen)
        assert np.array_equal(ev.fitness, fresh.fitness) and np.array_equal(ev.solved, fresh.solved)
        assert all(np.array_equal(getattr(ev.controllers, f), getattr(fresh.controllers, f))
                   for f in CONTROLLER_FIELDS)
        played_clean = list(tr.evaluator._clean_sims)[0]  # the noise-free episode ran for this many teams
        skipped.append(len(distinct_teams(ev.controllers)[0]) - played_clean)
        tr.population.tell(ev.fitness)
    assert skipped[0] == 0 and max(skipped[1:]) > 0  # elites' noise-free episodes were not played again


def test_a_noise_free_episode_on_the_map_is_remembered_across_its_changing_keys(monkeypatch):
    """With per-generation draws a noise-free keyed episode on the map gets a new key every generation, yet it draws
    nothing: a team the previous generation played there is not played again (its variant episode, whose map the key
    draws, is); the scores equal a fresh evaluator's."""
    from mahn_evo.hyperneat import team_evaluator

    settings = EvaluationSettings(task=TaskParams(max_cycles=240, signal_tick=120), episodes=2,
                                  noise_draws="per_generation", map_branch=49.0, branch_sides="one_short",
                                  plain_episodes=1, seed=3)
    teams = _batch([random_team(s) for s in (4, 5, 6)])
    played: list[tuple[str, int, int]] = []
    real = TeamEvaluator._play_training

    def counting(self, run, protocol, key):
        played.append((protocol, key, run.w_ih.shape[0]))
        return real(self, run, protocol, key)

    monkeypatch.setattr(team_evaluator.TeamEvaluator, "_play_training", counting)
    ev = TeamEvaluator(settings)
    ev.score(teams, 0)
    assert played == [("keyed", 0, 3), ("keyed", 1, 3)]
    played.clear()
    fit, solved = ev.score(teams, 1)
    assert played == [("keyed", 3, 3)]  # key 2 (on the map) is remembered from key 0; key 3 is a new variant
    fresh_fit, fresh_solved = TeamEvaluator(settings).score(teams, 1)
    assert np.array_equal(fit, fresh_fit) and np.array_equal(solved, fresh_solved)
    noisy = replace(settings, task=TaskParams(max_cycles=240, signal_tick=120, sensor_noise=5.0))
    ev = TeamEvaluator(noisy)
    ev.score(teams, 0)
    played.clear()
    ev.score(teams, 1)
    assert [p[1] for p in played] == [2, 3]  # under noise the key draws the noise: both played
