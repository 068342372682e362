"""The report's transfer tests under the robot noise (`--transfer-noise robot`): a real Khepera III's IR sensors and a
reflex that reads them, where the issue's test uses the generalisation noise (docs/results/emulator_check/)."""
from __future__ import annotations

from pathlib import Path

import pytest

from mahn_evo.experiment import ExperimentPlan
from mahn_evo.experiment.transfer import transfer_tests
from mahn_evo.training.champion import Champion

# robust under the generalisation noise (10/10 noisy sequential on plus), 0 of 10 through the emulated robots
S014 = Path(__file__).parents[2] / "docs" / "results" / "experiment_hardened_sequential" / "champions" / \
    "situational_s014.json"


def test_the_plan_names_its_transfer_noise_and_refuses_others():
    assert ExperimentPlan().transfer_noise == "generalization"
    assert ExperimentPlan(transfer_noise="robot").transfer_noise == "robot"
    with pytest.raises(ValueError, match="transfer_noise"):
        ExperimentPlan(transfer_noise="none")


def test_a_team_robust_to_the_generalisation_noise_fails_the_robot_noise():
    champ = Champion.load(S014)
    plan = ExperimentPlan(transfer_episodes=3, seed=1)
    plain = transfer_tests(champ, plan)
    robot = transfer_tests(champ, ExperimentPlan(transfer_episodes=3, seed=1, transfer_noise="robot"))
    assert plain["plus"]["sequential_noisy"]["success_fraction"] == 1.0
    assert robot["plus"]["sequential_noisy"]["success_fraction"] == 0.0
    # the exact (noise-free) columns do not depend on the noise
    assert robot["plus"]["sequential"] == plain["plus"]["sequential"]
    assert robot["plus"]["training"] == plain["plus"]["training"]
