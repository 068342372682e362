"""Behavioural-diversity selection: NEAT selects by fitness + weight x diversity; the task fitness decides the rest."""
from __future__ import annotations

import json

import numpy as np
import pytest

from mahn_envs.core import BatchSim
from mahn_evo.cli import build_parser, experiment_plan, main
from mahn_evo.experiment.report import _selection_text
from mahn_evo.hyperneat.team_evaluator import TeamEvaluator
from mahn_evo.training.config import EvolutionConfig
from mahn_evo.training.diversity import behavioural_diversity, selection_fitness
from mahn_evo.training.trainer import Trainer


def test_diversity_is_the_mean_distance_to_the_k_nearest_other_rows():
    b = np.array([[0.0, 0.0], [3.0, 4.0], [6.0, 8.0], [0.0, 0.0]])
    # row 0: others at 5, 10, 0 -> nearest two 0 and 5
    assert behavioural_diversity(b, 2).tolist() == [2.5, 5.0, 7.5, 2.5]
    assert behavioural_diversity(b, 1).tolist() == [0.0, 5.0, 5.0, 0.0]  # the copies are each other's nearest
    assert behavioural_diversity(b, 99).tolist() == pytest.approx([5.0, 5.0, 25 / 3, 5.0])  # k capped at N - 1
    assert behavioural_diversity(b[:1], 15).tolist() == [0.0]
    # (N, R, 2) end positions are flattened per team
    teams = b.reshape(2, 2, 2)  # [[0, 0], [3, 4]] and [[6, 8], [0, 0]]
    assert behavioural_diversity(teams, 1).tolist() == pytest.approx([np.sqrt(6**2 + 8**2 + 3**2 + 4**2)] * 2)
    with pytest.raises(ValueError, match="k must be a positive integer"):
        behavioural_diversity(b, 0)


def test_selection_fitness_without_weight_is_the_fitness_itself():
    fit = np.array([1.0, 2.0, 3.0])
    beh = np.array([[0.0], [1.0], [5.0]])
    assert selection_fitness(fit, beh, 0.0, 1) is fit
    assert selection_fitness(fit, beh, 0.5, 1).tolist() == [1.5, 2.5, 5.0]


def test_the_evaluator_reports_where_each_robot_ended_also_from_its_memo(tmp_path):
    cfg = EvolutionConfig(seed=3).with_overrides(pop=12)
    genomes = Trainer(cfg, tmp_path).population.ask()
    ev = TeamEvaluator(cfg.evaluation)
    first = ev.evaluate(genomes)
    assert first.end_positions.shape == (12, 3, 2)
    sim = BatchSim(cfg.map, 1, cfg.task)
    for i in (0, 5, 11):
        sim.run_controllers(first.controllers.team(i), seed=cfg.seed, episode_keys=np.array([0]))
        assert first.end_positions[i].tolist() == sim.pose[0, :, :2].tolist()
    again = ev.evaluate(genomes)  # every team remembered from the previous call
    assert again.end_positions.tolist() == first.end_positions.tolist()
    assert again.fitness.tolist() == first.fitness.tolist()


def _cfg(diversity: float, generations: int = 6) -> EvolutionConfig:
    return EvolutionConfig(generations=generations, seed=11, diversity=diversity, diversity_k=5).with_overrides(pop=30)


def test_neat_selects_by_the_bonus_while_logs_and_champions_keep_the_task_fitness(tmp_path, monkeypatch):
    tr = Trainer(_cfg(0.5), tmp_path / "d")
    told: list[np.ndarray] = []
    real_tell = tr.population.tell

    def tell(fitness):
        told.append(np.array(fitness))
        return real_tell(fitness)

    monkeypatch.setattr(tr.population, "tell", tell)
    genomes = tr.population.ask()
    ev = TeamEvaluator(tr.config.evaluation).evaluate(genomes, 0)
    tr.step()
    bonus = 0.5 * behavioural_diversity(ev.end_positions, 5)
    assert bonus.max() > 0
    assert told[0].tolist() == (ev.fitness + bonus).tolist()
    assert tr.rows[0][2] == float(ev.fitness.max())  # the log's best is the task's fitness
    champ = json.loads((tmp_path / "d" / "champion.json").read_text())
    assert champ["fitness"] == float(ev.fitness.max())


def test_diversity_changes_the_run_and_resumes_bit_identically(tmp_path):
    plain = Trainer(_cfg(0.0), tmp_path / "p")
    plain.run()
    full = Trainer(_cfg(1.0), tmp_path / "f")
    full.run()
    assert [r[:-1] for r in full.rows] != [r[:-1] for r in plain.rows]  # selection differs from generation 1
    half = Trainer(_cfg(1.0, generations=3), tmp_path / "h")
    half.run()
    resumed = Trainer(_cfg(1.0), tmp_path / "h", resume=True)
    resumed.run()
    assert [r[:-1] for r in resumed.rows] == [r[:-1] for r in full.rows]


def test_settings_are_checked_and_reach_config_json_and_the_experiment_plan(tmp_path):
    with pytest.raises(ValueError, match="diversity must be a non-negative number"):
        EvolutionConfig(diversity=-0.1)
    with pytest.raises(ValueError, match="diversity must be a non-negative number"):
        EvolutionConfig(diversity=float("nan"))
    with pytest.raises(ValueError, match="diversity_k must be a positive integer"):
        EvolutionConfig(diversity_k=0)
    out = tmp_path / "run"
    assert main(["train", "--generations", "2", "--pop", "12", "--diversity", "0.2", "--diversity-k", "4",
                 "--out", str(out), "--quiet"]) == 0
    saved = json.loads((out / "config.json").read_text())
    assert (saved["diversity"], saved["diversity_k"]) == (0.2, 4)
    args = build_parser().parse_args(["experiment", "--preset", "iros2011-multistep", "--diversity", "0.3",
                                      "--out", str(tmp_path / "e")])
    plan = experiment_plan(args)
    assert (plan.diversity, plan.diversity_k, plan.cppn_activation) == (0.3, 15, "relax")
    assert plan.train_config("situational", 1).diversity == 0.3
    assert "fitness + 0.3 x behavioural diversity" in _selection_text(plan.to_dict())
    assert _selection_text({"diversity": 0.0}) == ""
