"""Bilateral symmetry by construction (`symmetry="mirror"`): robot 0 is the exact mirror image of robot 2."""
from __future__ import annotations

import json

import numpy as np
import pytest

from mahn_evo.cli import build_parser, experiment_plan, main
from mahn_evo.cppn import compile_genome
from mahn_evo.experiment.report import _selection_text
from mahn_evo.hyperneat.substrate import decode_population, mirrored_teams
from mahn_evo.hyperneat.team_evaluator import EvaluationSettings
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
