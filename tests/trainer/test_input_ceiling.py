"""The input ceiling (TaskParams.input_ceiling), beyond the paper: sensor values at or above it read 1, so the
sensor noise cannot move the input of open space.  1 is the original's encoding and changes nothing; a run trained
with a ceiling records it in its config and champion, and every later use of the champion (evaluation, sequential
protocol, generalisation, deploy) encodes the team's inputs with it."""
from __future__ import annotations

import json

import numpy as np
import pytest

from mahn_envs.core import BatchSim, TaskParams, encode_inputs
from mahn_envs.core.task import P_CEIL
from mahn_envs.hardware import Sensing
from mahn_evo.cli import build_parser, experiment_plan, main
from mahn_evo.deploy import _champion_sensing
from mahn_evo.evaluation.eval_champion import evaluate_champion
from mahn_evo.experiment.report import _team_text
from mahn_evo.storage.files import read_versioned_json
from mahn_evo.training.champion import Champion
from mahn_evo.training.config import EvolutionConfig


def test_encode_inputs_reads_values_at_or_above_the_ceiling_as_open():
    readings = [[0.94, 0.95, 0.97, 1.2, 0.5, 0.2]]
    assert encode_inputs(readings, [0.0], ceiling=0.95).tolist() == [
        [float(np.float32(0.94)), 1.0, 1.0, 1.0, 0.5, 0.0, 0.0]]
    # the original's encoding (ceiling 1): only the cap at 1 and the floor
    assert encode_inputs(readings, [1.0]).tolist() == [
        [float(np.float32(v)) for v in (0.94, 0.95, 0.97)] + [1.0, 0.5, 0.0, 1.0]]


@pytest.mark.parametrize("bad", [0.3, 1.01, float("nan"), True, "0.95"])
def test_a_ceiling_out_of_range_is_refused_naming_the_field(bad):
    with pytest.raises(ValueError, match="input_ceiling"):
        TaskParams(input_ceiling=bad)
    with pytest.raises(ValueError, match="Sensing.input_ceiling"):
        Sensing(input_ceiling=bad)


def test_the_core_encodes_noisy_open_rays_as_open_under_the_ceiling():
    """With +-5 % IR noise an open ray reads within 5 % of 1; with the ceiling 0.95 none of them is left in
    [0.95, 1), and without it many are."""
    def near_open(ceiling: float) -> int:
        params = TaskParams(max_cycles=300, signal_tick=150, sensor_noise=5.0, input_ceiling=ceiling)
        sim = BatchSim("plus", 4, params)
        obs = sim.reset(seed=3)
        rng = np.random.default_rng(1)
        count = 0
        while not sim.done:
            count += int(np.sum((obs[..., :6] >= 0.95) & (obs[..., :6] < 1.0)))
            obs, _, _ = sim.step(rng.choice(3, size=(4, 3), p=[0.2, 0.6, 0.2]))
        return count

    assert near_open(1.0) > 100
    assert near_open(0.95) == 0
    assert TaskParams().vector()[P_CEIL] == 1.0  # the ceiling's slot holds the original's encoding by default


@pytest.fixture(scope="module")
def ceiling_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("ceiling") / "run"
    assert main(["train", "--mode", "situational", "--generations", "3", "--pop", "24", "--seed", "5",
                 "--input-ceiling", "0.9", "--noise", "generalization", "--out", str(out), "--quiet"]) == 0
    return out


def test_the_run_records_the_ceiling_and_its_champion_is_scored_with_it(ceiling_run):
    config = EvolutionConfig.from_saved(read_versioned_json(ceiling_run / "config.json", "config"))
    assert config.task.input_ceiling == 0.9 and config.task.sensor_noise > 0
    champ = Champion.load(ceiling_run / "champion.json")
    assert champ.input_ceiling == 0.9
    assert champ.task(TaskParams(sensor_noise=5.0)) == TaskParams(sensor_noise=5.0, input_ceiling=0.9)
    result = evaluate_champion(champ, map="plus")
    assert result["params"]["input_ceiling"] == 0.9
    # the training generation scored the champion under noise; its noise-free episode is the task without it
    noise_free = evaluate_champion(champ, map="plus", params=TaskParams())
    assert noise_free["params"]["input_ceiling"] == 0.9


def test_files_without_the_field_mean_the_original_encoding_and_a_bad_value_is_named(ceiling_run, tmp_path):
    data = json.loads((ceiling_run / "champion.json").read_text())
    del data["input_ceiling"]
    (tmp_path / "old.json").write_text(json.dumps(data))
    assert Champion.load(tmp_path / "old.json").input_ceiling == 1.0
    for bad in ("0.9", 0.1):
        (tmp_path / "bad.json").write_text(json.dumps({**data, "input_ceiling": bad}))
        with pytest.raises(ValueError, match="bad.json.*input_ceiling"):
            Champion.load(tmp_path / "bad.json")
    assert _champion_sensing(None, data, "old.json").input_ceiling == 1.0
    assert _champion_sensing(Sensing(calibration="linear"), {"input_ceiling": 0.95}, "c.json").input_ceiling == 0.95
    with pytest.raises(ValueError, match="c.json.*input_ceiling"):
        _champion_sensing(None, {"input_ceiling": 2.0}, "c.json")


def test_an_experiment_plan_carries_the_ceiling_into_each_run():
    args = build_parser().parse_args(["experiment", "--out", "x", "--runs", "1", "--input-ceiling", "0.95"])
    plan = experiment_plan(args)
    assert plan.input_ceiling == 0.95
    assert plan.train_config("situational", 1).task.input_ceiling == 0.95
    default = experiment_plan(build_parser().parse_args(["experiment", "--out", "x", "--runs", "1"]))
    assert default.train_config("situational", 1).task.input_ceiling == 1.0
    # the report's first line names it (and nothing for the original's encoding)
    assert "(`--input-ceiling 0.95`)" in _team_text(plan.to_dict())
    assert _team_text(default.to_dict()) == ""
