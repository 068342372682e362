"""The experiments' generalisation and transfer tests on the direct controls' best teams (IPOP-CMA-ES, situational).

Each solved run's best controllers (fair_runs/ipop_situational_seed*/best_controllers.json) go through what the
experiment report measures for HyperNEAT's most general solutions: 25 noisy training episodes on `plus` (the
generalisation test, seed 0), then `transfer_tests` (both maps, both protocols, exact and 10 noisy episodes, decision
margins; seed 1 as the published experiment).  A direct team has no CPPN, so it is wrapped in a Champion without a
genome (the tests read only its controllers and task).  Results are written per seed to transfer.json next to this
script, which is resumable: seeds already in it are skipped.

    python docs/results/baselines/fair_ipop/transfer.py
"""
from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np

from mahn_envs.policies.team_controllers import TeamControllers
from mahn_evo.evaluation.generalize import keyed_episodes
from mahn_evo.evaluation.task_setup import task_params
from mahn_evo.experiment.plan import ExperimentPlan
from mahn_evo.experiment.transfer import robust_on_every_map, transfer_tests
from mahn_evo.storage.files import atomic_write_json
from mahn_evo.training.champion import Champion

HERE = Path(__file__).resolve().parent
RUNS = HERE.parent / "fair_runs"
OUT = HERE / "transfer.json"
GENERAL_EPISODES = 25


def champion(path: Path) -> Champion:
    data = json.loads(path.read_text())
    ctrl = TeamControllers.from_dict(data["controllers"])
    return Champion(mode=data["controllers"]["mode"], fitness=float(data["fitness"]), solved=bool(data["solved"]),
                    generation=int(data["generation"]), genome=None, controllers=ctrl)  # type: ignore[arg-type]


def general(champ: Champion) -> dict:
    fit, solved = keyed_episodes(champ.controllers.as_batch(), "plus", champ.task(task_params("generalization")), 0,
                                 range(GENERAL_EPISODES))
    return {"solved_fraction": float(np.mean(solved)), "mean_fitness": float(np.mean(fit))}


def main() -> None:
    done = json.loads(OUT.read_text()) if OUT.exists() else {}
    plan = ExperimentPlan(modes=("situational",), seed=1)
    for path in sorted(RUNS.glob("ipop_situational_seed*/best_controllers.json"),
                       key=lambda p: int(p.parent.name.rsplit("seed", 1)[1])):
        name = path.parent.name
        champ = champion(path)
        if name in done or not champ.solved:
            continue
        row = {"general": general(champ), "transfer": transfer_tests(champ, plan)}
        row["robust"] = robust_on_every_map(row["transfer"])
        done[name] = row
        atomic_write_json(OUT, done)
        t = row["transfer"]
        print(name, row["general"]["solved_fraction"], t["plus"]["sequential_noisy"]["success_fraction"],
              t["asymmetric_plus"]["sequential_noisy"]["success_fraction"], row["robust"], flush=True, file=sys.stdout)


if __name__ == "__main__":
    main()
