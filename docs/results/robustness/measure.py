"""Transfer measures of trained champions: noise-free fitness, fitness under the generalisation noise, decision
margins, the sequential (real-world) protocol with noise on both maps, and the Khepera III emulator in lock-step
time.

Usage: python docs/results/robustness/measure.py OUT.json RUN_DIR [RUN_DIR ...]
Every measure is seeded; the emulator runs on a virtual clock (exact 33 ms ticks), so results do not depend on
the machine's load.
"""
from __future__ import annotations

import json
import sys
from pathlib import Path

from mahn_envs.hardware import Link, RetryPolicy
from mahn_envs.hardware.clock import VirtualClock
from mahn_envs.policies.controller_policy import ControllerPolicy
from mahn_evo.deploy import deploy
from mahn_evo.evaluation.eval_champion import evaluate_champion
from mahn_evo.evaluation.margins import decision_margins
from mahn_evo.evaluation.protocols import sequential
from mahn_evo.evaluation.task_setup import task_params
from mahn_evo.storage.files import atomic_write_json
from mahn_evo.training.champion import Champion

NOISY_EPISODES = 20
SEQUENTIAL_EPISODES = 10
SEQUENTIAL_MAPS = ("plus", "asymmetric_plus")
EMULATOR_SEEDS = (0, 1, 2)


def measure(run: Path) -> dict:
    path = run / "champion.json"
    champ = Champion.load(path)
    noisy = task_params("generalization")
    clean = evaluate_champion(champ, episodes=1)
    rough = evaluate_champion(champ, episodes=NOISY_EPISODES, params=noisy)
    margins = decision_margins(champ)
    policy = ControllerPolicy(champ.controllers, [f"robot_{k}" for k in range(champ.controllers.n_robots)])
    seq = {m: sequential(policy, map=m, params=noisy, episodes=SEQUENTIAL_EPISODES) for m in SEQUENTIAL_MAPS}
    emulated = []
    for s in EMULATOR_SEEDS:
        res = deploy(path, emulate=True, emulator_seed=s, clock=VirtualClock(),
                     env_kwargs={"link": Link(retry=RetryPolicy(timeout=2.0))}, log_path=run / f"emulator_s{s}.csv")
        emulated.append(res.team_fitness)
    return {"run": run.name, "training_fitness": champ.fitness, "generation": champ.generation,
            "noise_free_fitness": clean["fitness"], "noisy_mean_fitness": rough["fitness"],
            "noisy_solved_fraction": rough["solved_fraction"],
            "tied_fraction": margins["tied_fraction"], "near_tie_fraction": margins["near_tie_fraction"],
            "flipped_decisions": margins["flipped"],
            "decision": champ.controllers.decision,
            "sequential_successes": sum(seq["plus"]["solved"]), "sequential_episodes": SEQUENTIAL_EPISODES,
            "sequential_successes_by_map": {m: sum(seq[m]["solved"]) for m in SEQUENTIAL_MAPS},
            "emulator_fitness": emulated}


def main(argv: list[str]) -> None:
    out, runs = Path(argv[0]), [Path(a) for a in argv[1:]]
    rows = [measure(r) for r in runs]
    atomic_write_json(out, {"measures": rows, "noisy_episodes": NOISY_EPISODES,
                            "sequential_episodes": SEQUENTIAL_EPISODES, "emulator_seeds": list(EMULATOR_SEEDS)})
    for r in rows:
        print(json.dumps(r))


if __name__ == "__main__":
    main(sys.argv[1:])
