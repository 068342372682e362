"""Does success on the training family predict the test map?  For each run folder (with final_validation.json from
`mahn-evo final-validation --sequential T`): the chosen team's noisy sequential successes in N episodes on the run's
own plus variants (`--map-branch`/`--map-spread`, keys of their own, never trained on) and in 10 on `asymmetric_plus`
(the transfer test's episodes for an experiment of seed 1).
Usage: python family_vs_test.py N RUN_DIR...   (prints a markdown table)"""
from __future__ import annotations

import json
import sys
from pathlib import Path

from mahn_envs.maps import load_map
from mahn_envs.maps.variants import spread_variant
from mahn_evo.evaluation.eval_champion import champion_policy
from mahn_evo.evaluation.final_population import FAMILY_KEY, SEQUENTIAL_SEED, final_population
from mahn_evo.evaluation.protocols import sequential_episode
from mahn_evo.evaluation.task_setup import task_params
from mahn_evo.training.champion import Champion

#: the first seed of the test-map episodes: the transfer test's of the seeds 1-15 experiments (their plan's seed)
TEST_SEED = 1


def main(n: int, runs: list[str]) -> None:
    test = load_map("asymmetric_plus")
    print(f"| run | plus (validation, of 10) | family (of {n}) | asymmetric_plus (of 10) |")
    print("|---|---|---|---|")
    for run in map(Path, runs):
        record = json.loads((run / "final_validation.json").read_text())
        config, _ = final_population(run)
        champ = Champion.load(run / record["chosen"]["file"])
        params = champ.task(task_params("generalization"))
        ev = config.evaluation
        family = sum(sequential_episode(champion_policy(champ), spread_variant(
            config.seed, FAMILY_KEY + i, ev.map_spread, ev.map_branch, ev.branch_sides), params,
            seed=SEQUENTIAL_SEED + 100 + i).success for i in range(n))
        on_test = sum(sequential_episode(champion_policy(champ), test, params, seed=TEST_SEED + i).success
                      for i in range(10))
        plus = record["chosen"].get("sequential_successes", "-")
        print(f"| {run.name} | {plus} | {family} | {on_test} |", flush=True)


if __name__ == "__main__":
    main(int(sys.argv[1]), sys.argv[2:])
