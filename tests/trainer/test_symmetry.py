"""Bilateral symmetry by construction (`symmetry="mirror"`): robot 0 is the exact mirror image of robot 2."""
from __future__ import annotations

import json

import numpy as np
import pytest

from mahn_evo.cli import build_parser, experiment_plan, main
from mahn_evo.cppn import compile_genome
from mahn_evo.experiment.report import _selection_text
from mahn_evo.hyperneat.evaluation_settings import EvaluationSettings
from mahn_evo.hyperneat.substrate import decode_population, mirrored_teams
from mahn_evo.training.champion import Champion
from mahn_evo.training.config import EvolutionConfig
from mahn_evo.training.trainer import Trainer


def _genomes(tmp_path, mode: str = "situational", n: int = 6):
    return Trainer(EvolutionConfig(mode=mode, seed=4, init="minimal").with_overrides(pop=n), tmp_path).population.ask()


def _forward(c, r: int, k: int, obs: np.ndarray) -> np.ndarray:
    """Two synchronous steps of robot r's brain k from zero state (float64): its three outputs."""
    hid = np.zeros(c.w_hh.shape[-1])
    out = np.zeros(3)
    for _ in range(2):
        out = 1 / (1 + np.exp(-4.9 * (c.w_ho[r, k] @ hid + c.b_o[r, k])))
        hid = 1 / (1 + np.exp(-4.9 * (c.w_ih[r, k] @ obs + c.w_hh[r, k] @ hid + c.b_h[r, k])))
    return out


@pytest.mark.parametrize("mode", ["situational", "standard"])
def test_the_robot_at_minus_z_is_the_mirror_image_of_its_partner(tmp_path, mode):
    plans = [compile_genome(g) for g in _genomes(tmp_path, mode)]
    plain = decode_population(plans, mode)
    mirror = decode_population(plans, mode, symmetry="mirror")
    for f in ("w_ih", "w_hh", "w_ho", "b_h", "b_o"):  # robots 1 and 2 are painted as before
        assert np.array_equal(getattr(mirror, f)[:, 1:], getattr(plain, f)[:, 1:])
    assert not np.array_equal(plain.w_ih[:, 0], mirror.w_ih[:, 0])
    rng = np.random.default_rng(0)
    for team in range(len(plans)):
        c = mirror.team(team)
        for k in range(c.w_ih.shape[1]):
            obs = np.concatenate([rng.random(6), [1.0]])
            mirrored_obs = np.concatenate([obs[5::-1], obs[6:]])
            # robot 0 on the mirrored world = robot 2 on the world, left and right swapped
            assert _forward(c, 0, k, mirrored_obs) == pytest.approx(_forward(c, 2, k, obs)[::-1], abs=1e-5)


def test_mirroring_twice_changes_nothing_and_names_are_checked(tmp_path):
    plans = [compile_genome(g) for g in _genomes(tmp_path)]
    once = decode_population(plans, "situational", symmetry="mirror")
    twice = mirrored_teams(once)
    for f in ("w_ih", "w_hh", "w_ho", "b_h", "b_o"):
        assert np.array_equal(getattr(once, f), getattr(twice, f))
    with pytest.raises(ValueError, match="symmetry must be one of"):
        decode_population(plans, "situational", symmetry="left")
    with pytest.raises(ValueError, match="symmetry must be one of"):
        EvaluationSettings(symmetry="left")


def test_a_mirror_run_trains_saves_a_loadable_champion_and_records_the_setting(tmp_path):
    out = tmp_path / "run"
    assert main(["train", "--generations", "3", "--pop", "16", "--seed", "2", "--symmetry", "mirror",
                 "--out", str(out), "--quiet"]) == 0
    assert json.loads((out / "config.json").read_text())["symmetry"] == "mirror"
    champ = Champion.load(out / "champion.json")  # its controllers are checked against the CPPN's decodings
    c = champ.controllers
    assert np.array_equal(c.w_ih[0, :, :, :6], c.w_ih[2, :, ::-1, 5::-1])
    args = build_parser().parse_args(["experiment", "--preset", "iros2011-multistep", "--symmetry", "mirror",
                                      "--out", str(tmp_path / "e")])
    plan = experiment_plan(args)
    assert (plan.symmetry, plan.cppn_activation) == ("mirror", "relax")
    assert plan.train_config("situational", 1).evaluation.symmetry == "mirror"
    assert "mirror image of robot 2" in _selection_text(plan.to_dict())


def test_best_scores_every_reading_and_keeps_the_best_team(tmp_path):
    from mahn_evo.hyperneat.substrate import READINGS, team_reading
    from mahn_evo.hyperneat.team_evaluator import TeamEvaluator

    genomes = _genomes(tmp_path, n=10)
    best = TeamEvaluator(EvaluationSettings(symmetry="best"))
    plain = TeamEvaluator(EvaluationSettings())
    ev = best.evaluate(genomes)
    painted = plain.decode(genomes)
    per_reading = np.array([plain.score(team_reading(painted, r))[0] for r in READINGS])
    assert ev.fitness.tolist() == per_reading.max(axis=0).tolist()
    assert best.readings == 3 and plain.readings == 1
    for i in range(len(genomes)):
        chosen = READINGS[int(np.argmax(per_reading[:, i]))]  # the first reading on ties
        team = team_reading(painted, chosen).team(i)
        assert np.array_equal(ev.controllers.team(i).w_ih, team.w_ih)


def test_a_best_run_counts_three_teams_per_genome_and_its_champion_loads(tmp_path):
    out = tmp_path / "run"
    assert main(["train", "--generations", "3", "--pop", "16", "--seed", "2", "--symmetry", "best",
                 "--out", str(out), "--quiet"]) == 0
    assert json.loads((out / "summary.json").read_text())["evaluations"] == 3 * 16 * 3
    Champion.load(out / "champion.json")  # whichever reading it is, it matches its CPPN


def test_a_champion_may_hold_any_mirror_reading_of_its_cppn_but_not_another_team(tmp_path):
    from dataclasses import replace

    from mahn_evo.hyperneat.substrate import team_reading

    out = tmp_path / "run"
    assert main(["train", "--generations", "2", "--pop", "12", "--seed", "5", "--init", "minimal", "--out", str(out),
                 "--quiet"]) == 0
    champ = Champion.load(out / "champion.json")
    for reading in ("mirror", "mirror_minus"):
        flipped = team_reading(champ.controllers.as_batch(), reading).team(0)
        replace(champ, controllers=flipped).save(tmp_path / f"{reading}.json")
        Champion.load(tmp_path / f"{reading}.json")
    c = champ.controllers
    swapped = c.map_arrays(lambda a: a[[2, 1, 0]])  # robots 0 and 2 exchanged: no reading of the CPPN
    replace(champ, controllers=swapped).save(tmp_path / "swapped.json")
    with pytest.raises(ValueError, match="does not match what field 'cppn' decodes to"):
        Champion.load(tmp_path / "swapped.json")


def test_the_published_mirror_readings_experiment_is_the_documented_command():
    from pathlib import Path

    from mahn_evo.experiment.plan import ExperimentPlan

    published = ExperimentPlan.load(Path(__file__).parents[2] / "docs" / "results" / "experiment_best")
    args = build_parser().parse_args(["experiment", "--modes", "situational", "--runs", "15", "--seed", "1",
                                      "--generations", "1000", "--after-solved", "50", "--preset",
                                      "iros2011-multistep", "--symmetry", "best"])
    assert experiment_plan(args) == published


@pytest.mark.parametrize("noise", ["none", "generalization"])
def test_best_plays_each_robot_of_the_three_readings_once_with_the_same_scores(tmp_path, monkeypatch, noise):
    """A genome's three readings share 4 of their 9 robots (each at the same place), and robots blind to each other
    play alone: the evaluator plays 5 robot episodes per genome, not 9, and scores every team exactly as its own
    episode would (the team path, forced here, gives the same fitness, solved fractions and end positions)."""
    from mahn_evo.evaluation.task_setup import task_params
    from mahn_evo.hyperneat import team_evaluator
    from mahn_evo.hyperneat.team_evaluator import TeamEvaluator

    trainer = Trainer(EvolutionConfig(mode="situational", seed=4, init="minimal").with_overrides(pop=12), tmp_path)
    for _ in range(3):  # a few generations, so that the teams drive about
        trainer.step()
    genomes = trainer.population.ask()
    settings = EvaluationSettings(symmetry="best", episodes=2, noise_free_episode=noise != "none",
                                  noise_draws="per_generation", task=task_params(noise))
    played: list[int] = []
    real = team_evaluator.robot_episodes

    def counting(ctrl):
        carriers, robots, src = real(ctrl)
        played.append(sum(bin(int(m)).count("1") for m in robots))
        return carriers, robots, src

    monkeypatch.setattr(team_evaluator, "robot_episodes", counting)
    by_robot = TeamEvaluator(settings).evaluate(genomes, 7)
    # the training episodes (noise-free, the two keyed ones on the map are one episode), at most 5 robots per genome
    assert len(played) == (1 if noise == "none" else 3)
    assert all(p <= 5 * len(genomes) for p in played)

    def whole_teams(ctrl):  # every team plays its own episode
        n = ctrl.w_ih.shape[0]
        return np.arange(n), np.full(n, 7), np.arange(n)[:, None].repeat(3, axis=1)

    monkeypatch.setattr(team_evaluator, "robot_episodes", whole_teams)
    by_team = TeamEvaluator(settings).evaluate(genomes, 7)
    assert np.array_equal(by_robot.fitness, by_team.fitness)
    assert np.array_equal(by_robot.solved, by_team.solved)
    assert np.array_equal(by_robot.end_positions, by_team.end_positions)
    assert len(set(by_team.fitness.round(9))) > 2  # the genomes differ
