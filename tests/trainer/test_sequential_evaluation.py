"""Sequential-protocol episodes in evolution (EvaluationSettings.sequential_episodes): teams scored on the protocol
the robustness test plays, in the batch core, aggregated with the training episodes."""
from __future__ import annotations

import json
from dataclasses import replace

import numpy as np
import pytest

from mahn_envs.core.sequential import play_sequential
from mahn_evo.cli import main
from mahn_evo.hyperneat.evaluation_settings import EvaluationSettings
from mahn_evo.hyperneat.team_evaluator import (
    SEQUENTIAL_KEY,
    SEQUENTIAL_SUCCESS_FITNESS,
    TeamEvaluator,
    sequential_fitness,
)
from mahn_evo.training.champion import Champion
from mahn_evo.training.config import EvolutionConfig
from mahn_evo.training.trainer import Trainer, train
from tests.envs.helpers import BRITTLE_TEAM, ROBUST_TEAM

ROBUST, BRITTLE = ROBUST_TEAM, BRITTLE_TEAM
NOISY = EvolutionConfig().with_noise("generalization").task


def test_the_fitness_is_above_100_exactly_on_success():
    f = sequential_fitness(np.array([9, 8, 0, 9]), np.array([True, False, False, True]), 3)
    assert f.tolist() == [SEQUENTIAL_SUCCESS_FITNESS, pytest.approx(800 / 9), 0.0, SEQUENTIAL_SUCCESS_FITNESS]
    assert f[0] > 100 > f[1]


def test_sequential_episodes_score_teams_on_the_protocol_in_the_batch_core():
    """Two published teams (one that passes the noisy protocol, one that fails it) through an evaluator with one
    training episode and two sequential ones: each sequential score is the core's protocol episode for the
    generation's key; keys are fresh per generation and shared by the teams."""
    robust, brittle = Champion.load(ROBUST), Champion.load(BRITTLE)
    settings = EvaluationSettings(task=NOISY, episodes=1, noise_draws="per_generation", sequential_episodes=2,
                                  seed=3)
    ev = TeamEvaluator(settings)
    assert ev.sequential_keys(0) == [SEQUENTIAL_KEY, SEQUENTIAL_KEY + 1]
    assert ev.sequential_keys(4) == [SEQUENTIAL_KEY + 8, SEQUENTIAL_KEY + 9]
    from mahn_envs.policies.team_controllers import TeamControllers

    teams = TeamControllers(*(np.stack([getattr(robust.controllers, f), getattr(brittle.controllers, f)])
                              for f in ("w_ih", "w_hh", "w_ho", "b_h", "b_o")))
    fitness, solved, _ = ev.outcomes(teams, generation=4)
    plain, plain_solved, _ = TeamEvaluator(replace(settings, sequential_episodes=0)).outcomes(teams, generation=4)
    for b, champ in enumerate((robust, brittle)):
        seq = [play_sequential("plus", champ.controllers, NOISY, seed=3, episode_keys=[k])
               for k in ev.sequential_keys(4)]
        seq_fit = [sequential_fitness(s.stages_completed, s.success, 3)[0] for s in seq]
        assert fitness[b] == pytest.approx((plain[b] + sum(seq_fit)) / 3, abs=1e-9)
        assert solved[b] == pytest.approx((plain_solved[b] + sum(bool(s.success[0]) for s in seq)) / 3)
    assert fitness[0] > fitness[1]  # the team that passes the protocol now scores higher
    # without sequential episodes nothing changes: the same scores as an evaluator that never knew of them
    assert np.array_equal(plain, TeamEvaluator(EvaluationSettings(task=NOISY, episodes=1, noise_draws="per_generation",
                                                                  seed=3)).outcomes(teams, generation=4)[0])
    with pytest.raises(ValueError, match="sequential_episodes must be a non-negative integer"):
        EvaluationSettings(sequential_episodes=-1)


def _config(**kw):
    base = dict(generations=3, seed=5, episodes=1, noise_draws="per_generation", sequential_episodes=1)
    base.update(kw)
    return EvolutionConfig(**base).with_overrides(pop=12).with_noise("generalization")


@pytest.mark.parametrize("symmetry", ["none", "best"])
def test_training_with_sequential_episodes_is_deterministic_resumes_and_is_saved(tmp_path, symmetry, monkeypatch):
    """Also with symmetry "best", whose readings stop playing sequential episodes once they cannot be the best."""
    full = train(_config(symmetry=symmetry), tmp_path / "full")
    part = Trainer(_config(generations=2, symmetry=symmetry), tmp_path / "part")
    part.run()
    resumed = train(_config(symmetry=symmetry), tmp_path / "part", resume=True)
    assert resumed["best_fitness"] == full["best_fitness"]
    rows = [[r.split(",")[:8] for r in (tmp_path / run / "log.csv").read_text().splitlines()]
            for run in ("full", "part")]
    assert rows[0] == rows[1] and len(rows[0]) == 4  # header and 3 generations, equal but for the timings
    # evaluations count the sequential episodes too, for every reading (the nominal budget)
    assert int(rows[0][-1][1]) == 3 * 12 * 2 * (3 if symmetry == "best" else 1)
    if symmetry == "best":  # the same run as when every reading plays every episode
        def every_reading(self, batch, k, generation=0):
            fitness, solved, ends = self.outcomes(batch, generation)
            n = fitness.shape[0] // k
            best = np.argmax(fitness.reshape(k, n), axis=0)
            rows = best * n + np.arange(n)
            return fitness[rows], solved[rows], ends[rows], best

        monkeypatch.setattr(TeamEvaluator, "_best_outcomes", every_reading)
        train(_config(symmetry=symmetry), tmp_path / "every")
        every = [r.split(",")[:8] for r in (tmp_path / "every" / "log.csv").read_text().splitlines()]
        assert every == rows[0]
        return
    assert json.loads((tmp_path / "full" / "config.json").read_text())["sequential_episodes"] == 1
    # a robust-phase setting: the noise-free phase of robust_from first_solution does not play them
    cfg = replace(_config(), robust_from="first_solution")
    assert cfg.noise_free_evaluation.sequential_episodes == 0 and cfg.evaluation.sequential_episodes == 1
    # the CLI passes it on
    out = tmp_path / "cli"
    assert main(["train", "--generations", "1", "--pop", "8", "--noise", "generalization", "--episodes", "1",
                 "--noise-draws", "per_generation", "--sequential-episodes", "1", "--quiet", "--out", str(out)]) == 0
    assert json.loads((out / "config.json").read_text())["sequential_episodes"] == 1


def test_with_map_branch_the_sequential_episodes_play_on_their_keys_plus_variants():
    from mahn_envs.maps.variants import spread_variant

    robust = Champion.load(ROBUST)
    settings = EvaluationSettings(task=NOISY, episodes=1, noise_draws="per_generation", sequential_episodes=1, seed=3,
                                  map_branch=49.0, branch_sides="one_short", plain_episodes=1)
    ev = TeamEvaluator(settings)
    fitness, _, _ = ev.outcomes(robust.controllers.as_batch(), generation=2)
    plain, _, _ = TeamEvaluator(replace(settings, sequential_episodes=0)).outcomes(robust.controllers.as_batch(), 2)
    key = ev.sequential_keys(2)[0]
    variant = spread_variant(3, key, 0.0, 49.0, "one_short")
    seq = play_sequential(variant, robust.controllers, NOISY, seed=3, episode_keys=[key])
    on_plus = play_sequential("plus", robust.controllers, NOISY, seed=3, episode_keys=[key])
    assert fitness[0] == pytest.approx((plain[0] + sequential_fitness(seq.stages_completed, seq.success, 3)[0]) / 2)
    assert not np.array_equal(seq.records, on_plus.records)  # another map: another episode


def test_sequential_plain_keeps_the_first_sequential_episodes_of_a_generation_on_the_map():
    """`sequential_plain` 1 of 2 (with map_branch): in every generation the first sequential episode is the core's
    protocol episode on plus, the second on its key's variant; the option needs variants and at most S episodes,
    belongs to the robust phase, and the CLI, plan and report carry it."""
    from mahn_envs.maps.variants import spread_variant
    from mahn_evo.cli import build_parser, experiment_plan
    from mahn_evo.experiment.report import _robust_text

    brittle = Champion.load(BRITTLE)
    settings = EvaluationSettings(task=NOISY, episodes=1, noise_draws="per_generation", sequential_episodes=2, seed=3,
                                  map_branch=49.0, branch_sides="one_short", plain_episodes=1, sequential_plain=1)
    team = brittle.controllers.as_batch()
    plain, _, _ = TeamEvaluator(replace(settings, sequential_episodes=0, sequential_plain=0)).outcomes(team, 3)
    for generation in (0, 3):
        ev = TeamEvaluator(settings)
        first, second = ev.sequential_keys(generation)
        on_plus = play_sequential("plus", brittle.controllers, NOISY, seed=3, episode_keys=[first])
        on_variant = play_sequential(spread_variant(3, second, 0.0, 49.0, "one_short"), brittle.controllers, NOISY,
                                     seed=3, episode_keys=[second])
        fitness, _, _ = ev.outcomes(team, generation=generation)
        if generation == 3:
            seq = sum(sequential_fitness(s.stages_completed, s.success, 3)[0] for s in (on_plus, on_variant))
            assert fitness[0] == pytest.approx((plain[0] + seq) / 3, abs=1e-9)
        # the first key's own variant is another episode (generation 3: 9 stages on plus, 5 on it)
        mixed = play_sequential(spread_variant(3, first, 0.0, 49.0, "one_short"), brittle.controllers, NOISY,
                                seed=3, episode_keys=[first])
        assert generation != 3 or (on_plus.stages_completed[0], mixed.stages_completed[0]) == (9, 5)
    # all on variants (the default) is another score
    assert TeamEvaluator(replace(settings, sequential_plain=0)).outcomes(team, 3)[0][0] != fitness[0]
    with pytest.raises(ValueError, match="sequential_plain must be an integer in"):
        EvaluationSettings(map_branch=40.0, sequential_episodes=1, sequential_plain=2)
    with pytest.raises(ValueError, match="needs map_spread or map_branch"):
        EvaluationSettings(sequential_episodes=1, sequential_plain=1)
    parser = build_parser()
    plan = experiment_plan(parser.parse_args(
        "experiment --out x --runs 2 --seed 1 --preset best-restarts --noise generalization --episodes 3 "
        "--noise-draws per_generation --map-branch 49 --branch-sides one_short --plain-episodes 1 "
        "--sequential-episodes 2 --sequential-plain 1 --robust-from first_solution".split()))
    config = plan.train_config("situational", 1)
    assert config.evaluation.sequential_plain == 1 and config.noise_free_evaluation.sequential_plain == 0
    assert "the first 1 on the map itself: `--sequential-plain 1`" in _robust_text(plan.to_dict())


@pytest.mark.parametrize("aggregate", ["mean", "min", "quantile"])
def test_the_best_of_alternatives_is_that_of_every_alternative_scored_with_fewer_sequential_ticks(aggregate,
                                                                                                 monkeypatch):
    """`_best_outcomes` (symmetry "best": each genome's best reading) plays a team's other alternatives' sequential
    episodes only while they can still reach its leader, and stops them once they cannot: the fitness, solved
    fraction, end positions and choice are those of scoring every alternative in full, with fewer ticks played."""
    from mahn_envs.core.batch import BatchSim
    from mahn_envs.policies.team_controllers import TeamControllers
    from tests.envs.helpers import random_team

    robust, brittle = Champion.load(ROBUST).controllers, Champion.load(BRITTLE).controllers
    # 5 teams x 3 alternatives (rows a * 5 + i); duplicates across teams and within one team.  In generation 2
    # the brittle team scores more than the robust one in the training episodes, less with the sequential ones:
    # team 1's leader (brittle) is not its best; team 4's random alternatives are stopped within an episode
    alts = [[robust, brittle, brittle, random_team(2), random_team(30)],
            [random_team(3), random_team(1), random_team(4), random_team(2), random_team(31)],
            [brittle, robust, random_team(5), random_team(6), random_team(32)]]
    flat = [t for row in alts for t in row]
    batch = TeamControllers(*(np.stack([getattr(t, f) for t in flat]) for f in ("w_ih", "w_hh", "w_ho", "b_h", "b_o")))
    settings = EvaluationSettings(task=NOISY, episodes=2, noise_draws="per_generation", sequential_episodes=2,
                                  aggregate=aggregate, seed=3)
    ticks = {"played": 0, "cut": 0}
    run = BatchSim.run_sequential

    def counted(self, *args, **kw):
        out = run(self, *args, **kw)
        ticks["played"] += int(out.ticks.sum())
        ticks["cut"] += int(out.cut.sum())
        return out

    monkeypatch.setattr(BatchSim, "run_sequential", counted)
    fitness, solved, ends = TeamEvaluator(settings).outcomes(batch, generation=2)
    every = dict(ticks)
    best = np.argmax(fitness.reshape(3, 5), axis=0)
    rows = best * 5 + np.arange(5)
    ticks.update(played=0, cut=0)
    pruning = TeamEvaluator(settings)
    f, s, e, b = pruning._best_outcomes(batch, 3, generation=2)
    assert np.array_equal(b, best) and np.array_equal(f, fitness[rows])
    training = TeamEvaluator(replace(settings, sequential_episodes=0)).outcomes(batch, generation=2)[0]
    assert np.argmax(training.reshape(3, 5)[:, 1]) == 0 and b[1] == 2
    assert np.array_equal(s, solved[rows]) and np.array_equal(e, ends[rows])
    assert every["cut"] == 0 and ticks["played"] < every["played"]
    if aggregate == "mean":
        assert ticks["cut"] > 0  # alternatives stopped within an episode, not only skipped
    # what the pruning call remembers (`memo`) is exact: every alternative scored again from its memo
    again = pruning.outcomes(batch, generation=2)
    assert all(np.array_equal(x, y) for x, y in zip(again, (fitness, solved, ends)))
    with pytest.raises(ValueError, match="not 4 alternatives"):
        TeamEvaluator(settings)._best_outcomes(batch, 4)
