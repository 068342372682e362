"""The arcing reflex (TaskParams.reflex_arc), beyond the paper: a run trained with it records it in its config and
champion, and every later use of the champion (evaluation, sequential protocol, margins, deploy) drives the team
with it, while files without the field keep the original's reflex."""
from __future__ import annotations

import json
from dataclasses import replace

import pytest

from mahn_envs.core import BatchSim, TaskParams
from mahn_envs.hardware import Driving
from mahn_envs.policies.controller_policy import ControllerPolicy
from mahn_evo.cli import build_parser, experiment_plan, main
from mahn_evo.deploy import _champion_driving
from mahn_evo.evaluation.eval_champion import evaluate_champion
from mahn_evo.evaluation.protocols import sequential_episode
from mahn_evo.experiment.plan import ExperimentPlan
from mahn_evo.storage.files import read_versioned_json
from mahn_evo.training.champion import Champion
from mahn_evo.training.config import EvolutionConfig


@pytest.fixture(scope="module")
def arc_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("arc") / "run"
    assert main(["train", "--mode", "situational", "--generations", "3", "--pop", "24", "--seed", "5",
                 "--reflex-arc", "--out", str(out), "--quiet"]) == 0
    return out


def test_the_run_records_the_arcing_reflex_and_its_champion_is_scored_with_it(arc_run):
    config = EvolutionConfig.from_saved(read_versioned_json(arc_run / "config.json", "config"))
    assert config.task.reflex_arc is True
    champ = Champion.load(arc_run / "champion.json")
    assert champ.reflex_arc is True
    assert champ.task().reflex_arc is True
    assert champ.task(TaskParams(sensor_noise=5.0)) == TaskParams(sensor_noise=5.0, reflex_arc=True)
    result = evaluate_champion(champ, map="plus")
    assert result["params"]["reflex_arc"] is True
    assert result["fitness"] == pytest.approx(champ.fitness, abs=1e-9)  # the exact training episode again
    ep = sequential_episode(ControllerPolicy(champ.controllers, ["robot_0", "robot_1", "robot_2"]), "plus",
                            champ.task(), seed=0)
    assert ep.robots  # the protocol runs with the champion's reflex


def test_files_without_the_field_mean_the_original_reflex_and_a_bad_value_is_named(arc_run, tmp_path):
    data = json.loads((arc_run / "champion.json").read_text())
    del data["reflex_arc"]
    (tmp_path / "old.json").write_text(json.dumps(data))
    assert Champion.load(tmp_path / "old.json").reflex_arc is False
    (tmp_path / "bad.json").write_text(json.dumps({**data, "reflex_arc": "yes"}))
    with pytest.raises(ValueError, match="reflex_arc"):
        Champion.load(tmp_path / "bad.json")
    assert _champion_driving(None, data, "old.json") == Driving()
    assert _champion_driving(Driving(reflex=True), {"reflex_arc": True}, "c.json") == Driving(reflex_arc=True)
    with pytest.raises(ValueError, match="c.json.*reflex_arc"):
        _champion_driving(None, {"reflex_arc": 1}, "c.json")
    with pytest.raises(ValueError, match="Driving.reflex_arc"):
        Driving(reflex_arc="no")


def test_the_kernel_drives_the_arcing_reflex_differently_from_the_original():
    """A team that alternates a turn with forward: with the original's reflex a robot beside a wall may stand turning
    back and forth; with the arcing reflex every side-branch forward moves it, so the paths differ."""
    import numpy as np

    paths = {}
    for arc in (False, True):
        sim = BatchSim("plus", 1, TaskParams(max_cycles=400, signal_tick=210, reflex_arc=arc))
        sim.reset(seed=0)
        t = 0
        while not sim.done:
            sim.step(np.full((1, 3), 0 if t % 6 == 0 else 1))
            t += 1
        paths[arc] = sim.pose[0, :, :2].copy()
    assert not np.allclose(paths[False], paths[True])


def test_train_and_experiment_pass_the_flag_to_every_run():
    args = build_parser().parse_args(["experiment", "--out", "x", "--modes", "situational", "--reflex-arc"])
    plan = experiment_plan(args)
    assert plan.reflex_arc is True
    assert plan.train_config("situational", 1).task.reflex_arc is True
    assert ExperimentPlan().train_config("situational", 1).task.reflex_arc is False
    args = build_parser().parse_args(["experiment", "--out", "x", "--modes", "situational"])
    assert experiment_plan(args).reflex_arc is False


def _arc_hardening(**kw) -> EvolutionConfig:
    cfg = EvolutionConfig(generations=6, seed=7, episodes=2, noise_draws="per_generation",
                          noise_free_episode=True).with_overrides(pop=24).with_noise("generalization")
    cfg = cfg.with_overrides(robust_from="first_solution")
    return replace(cfg, task=replace(cfg.task, reflex_arc=True), **kw)


def test_reflex_arc_from_robust_phase_keeps_the_faithful_search_and_hardens_with_the_arcing_reflex(tmp_path):
    """Before the first solution the run is the noise-free run with the original's reflex, bit for bit (and its
    champions say so); the robust phase scores with the arcing reflex and its champions record it."""
    from mahn_evo.training.trainer import Trainer

    hard = Trainer(_arc_hardening(reflex_arc_from="robust_phase"), tmp_path / "h")
    clean = Trainer(EvolutionConfig(generations=6, seed=7).with_overrides(pop=24), tmp_path / "c")
    for _ in range(2):
        hard.step()
        clean.step()
    assert [r[:-1] for r in hard.rows] == [r[:-1] for r in clean.rows]
    assert hard.noise_free_evaluator is not None and hard.noise_free_evaluator.settings == clean.evaluator.settings
    assert Champion.load(tmp_path / "h" / "champion.json").reflex_arc is False
    hard.first_solved = 1  # as if generation 1 had held a solution: the robust phase starts at generation 2
    hard.step()
    assert hard.evaluator.settings.task.reflex_arc is True
    champ = Champion.load(tmp_path / "h" / "champion.json")
    assert champ.generation == 2 and champ.reflex_arc is True
    # from the start, the arcing reflex scores the noise-free phase too
    assert Trainer(_arc_hardening(), tmp_path / "s").noise_free_evaluator.settings.task.reflex_arc is True


def test_reflex_arc_from_is_checked():
    with pytest.raises(ValueError, match="reflex_arc_from must be one of"):
        _arc_hardening(reflex_arc_from="later")
    cfg = _arc_hardening()
    with pytest.raises(ValueError, match="needs the arcing reflex"):
        replace(cfg, task=replace(cfg.task, reflex_arc=False), reflex_arc_from="robust_phase")
    with pytest.raises(ValueError, match="needs the arcing reflex"):
        EvolutionConfig(task=TaskParams(reflex_arc=True), reflex_arc_from="robust_phase")
    args = build_parser().parse_args(["experiment", "--out", "x", "--modes", "situational", "--noise",
                                      "generalization", "--robust-from", "first_solution", "--after-solved", "10",
                                      "--reflex-arc", "--reflex-arc-from", "robust_phase"])
    plan = experiment_plan(args)
    config = plan.train_config("situational", 3)
    assert (config.reflex_arc_from, config.task.reflex_arc) == ("robust_phase", True)
    assert config.noise_free_evaluation.task.reflex_arc is False
