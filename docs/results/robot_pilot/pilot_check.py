"""A run's robot team, tested every way this project can: the report's transfer test, the same protocol under the
robot noise, the compiled core under sensor variants, and the emulated robots.

For each run folder: its final-validation pick (`mahn-evo final-validation --sequential 1000 --family-episodes 20
--engine batch`, run first if the folder has none; the run's own noise preset), then
  - `transfer`: the report's transfer test (`mahn_evo.experiment.transfer.transfer_tests` with the plan of
    EXPERIMENT: 10 noisy sequential episodes per map with the generalisation noise), success fractions;
  - `robot_sequential`: the same 10 sequential episodes per map under `--noise robot`;
  - `core`: 100 training-protocol episodes on plus per sensor variant (../emulator_check/sensor_parts.py);
  - `emulator`: the training protocol on plus through the emulated robots, once without sensor noise and 10 times
    with (../emulator_check/emulator_episodes.py).
One JSON line per run.

Usage: python docs/results/robot_pilot/pilot_check.py EXPERIMENT RUN_DIR... > pilot.jsonl
"""
from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np

from mahn_envs.core.batch import BatchSim
from mahn_evo.evaluation.eval_champion import champion_policy
from mahn_evo.evaluation.final_population import validate_final_population
from mahn_evo.evaluation.protocols import sequential
from mahn_evo.evaluation.task_setup import task_params
from mahn_evo.experiment.plan import ExperimentPlan
from mahn_evo.experiment.transfer import TRANSFER_MAPS, final_pick, transfer_tests
from mahn_evo.training.champion import Champion

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "emulator_check"))
from emulator_episodes import episode  # noqa: E402
from sensor_parts import variants  # noqa: E402


def check(run: Path, plan: ExperimentPlan) -> dict:
    if final_pick(run) is None:
        validate_final_population(run, episodes=25, sequential_teams=1000, family_episodes=20, engine="batch")
    chosen = final_pick(run)
    if chosen is None:
        return {"run": str(run), "pick": None}
    champ = Champion.load(run / chosen["file"])
    transfer = transfer_tests(champ, plan)
    robot = champ.task(task_params("robot"))
    row: dict = {"run": str(run), "pick": chosen["file"], "validation_noise": json.loads(
        (run / "final_validation.json").read_text())["noise"],
        "validation_plus": chosen.get("sequential_successes"), "validation_variants": chosen.get("family_successes"),
        "transfer": {m: transfer[m]["sequential_noisy"]["success_fraction"] for m in TRANSFER_MAPS},
        "robot_sequential": {m: float(np.mean(sequential(champion_policy(champ), map=m, params=robot, episodes=10,
                                                         seed=plan.seed)["solved"])) for m in TRANSFER_MAPS}}
    core = {}
    for name, params in variants().items():
        sim = BatchSim("plus", 100, champ.task(params))
        core[name] = round(float(sim.run_controllers(champ.controllers, seed=1, episode_keys=np.arange(100))
                                 .solved.mean()), 2)
    row["core"] = core
    f0, s0 = episode(champ, 0.0, 0)
    noisy = [episode(champ, 1.0, s) for s in range(10)]
    row["emulator"] = {"noise_free": [round(f0, 2), s0], "noisy_solved": sum(r[1] for r in noisy),
                       "noisy_fitness": [round(r[0], 1) for r in noisy]}
    return row


def main() -> None:
    plan = ExperimentPlan.load(Path(sys.argv[1]))
    for run in sys.argv[2:]:
        print(json.dumps(check(Path(run), plan)), flush=True)


if __name__ == "__main__":
    if len(sys.argv) < 3:
        raise SystemExit(__doc__)
    main()
