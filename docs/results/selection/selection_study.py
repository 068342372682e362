"""Selection study: what the final populations of hardened runs hold, measured in the compiled core, and whether
the core's noisy sequential episodes predict the pymunk transfer test.

For each run folder: the pool is every (team, reading) of the final population that solves the noise-free task on
plus, and every archived solution.  Each plays 20 noisy sequential episodes on plus and one on each of 20 of the
run's own plus variants in the compiled core (episode keys from 5 * 2**40 and 5 * 2**40 + 2**20: never a
training, validation or transfer-test key).  The 3 best (most successes on both, then on the variants) are then
played exactly as the experiment's transfer test plays a team: 10 noisy sequential episodes in pymunk, seed 1, on
plus and on asymmetric_plus.

    python docs/results/selection/selection_study.py EXPERIMENT_FOLDER/runs/situational_s0* > rows.jsonl
    python docs/results/selection/selection_study.py --csv selection_study.csv nfb1.jsonl seq1.jsonl ...

The published rows (selection_study.csv) were measured on experiment_one_sided_start_seeds_1_15's and
experiment_sequential_seeds_1_15's run folders (not in the repository: their champions are).
"""
from __future__ import annotations

import argparse
import csv
import json
import sys
from pathlib import Path

import numpy as np

from mahn_envs.core.batch import BatchSim
from mahn_envs.core.sequential import SequentialSettings, sequential_task
from mahn_envs.maps import World, load_map
from mahn_envs.maps.variants import spread_variant
from mahn_envs.policies.team_controllers import TeamControllers
from mahn_evo.evaluation.eval_champion import champion_policy
from mahn_evo.evaluation.final_population import final_population
from mahn_evo.evaluation.generalize import keyed_episodes
from mahn_evo.evaluation.protocols import sequential
from mahn_evo.evaluation.task_setup import task_params
from mahn_evo.hyperneat.substrate import READINGS, team_reading
from mahn_evo.hyperneat.team_evaluator import TeamEvaluator
from mahn_evo.training.champion import Champion
from mahn_evo.training.config import EvolutionConfig

STUDY_KEY = 5 << 40
FAMILY_OFFSET = 1 << 20


def pool(run: Path) -> tuple[EvolutionConfig, list[TeamControllers], list[str]]:
    """The run's noise-free solvers: final population x readings, and its archived solutions."""
    config, population = final_population(run)
    ctrl = TeamEvaluator(config.evaluation).decode(population.genomes)
    readings = READINGS if config.symmetry == "best" else ("none",)
    clean = config.task.without_noise()
    teams, names = [], []
    for reading in readings:
        batch = team_reading(ctrl, reading)
        _, ok = keyed_episodes(batch, config.map, clean, config.seed, [0])
        for i in np.flatnonzero(ok[:, 0]):
            teams.append(batch.team(int(i)))
            names.append(f"final_g{population.generation}_i{i}_{reading}")
    for path in sorted((run / "archive").glob("solution_g*.json")):
        teams.append(Champion.load(path).controllers)
        names.append(path.name)
    return config, teams, names


def core_successes(config: EvolutionConfig, teams: list[TeamControllers], worlds: list[World],
                   first_key: int) -> np.ndarray:
    """Each team's successes over one compiled-core noisy sequential episode per world (keys first_key + w)."""
    task = sequential_task(task_params("generalization").with_team_settings(config.task),
                           SequentialSettings())
    ctrl = TeamControllers.stack(teams)
    total = np.zeros(len(teams), dtype=int)
    for w, world in enumerate(worlds):
        rec = BatchSim(world, len(teams), task).run_sequential(
            ctrl, seed=config.seed, episode_keys=np.full(len(teams), first_key + w, dtype=np.int64))
        total += rec.success.astype(int)
    return total


def study(run: Path, episodes: int = 20, verify: int = 3) -> dict:
    config, teams, names = pool(run)
    if not teams:
        return {"run": run.name, "pool": 0}
    ev = config.evaluation
    family = [spread_variant(config.seed, STUDY_KEY + FAMILY_OFFSET + i, ev.map_spread, ev.map_branch,
                             ev.branch_sides) for i in range(episodes)]
    on_plus = core_successes(config, teams, [load_map(config.map)] * episodes, STUDY_KEY)
    on_family = core_successes(config, teams, family, STUDY_KEY + FAMILY_OFFSET)
    order = sorted(range(len(teams)), key=lambda i: (-(on_plus[i] + on_family[i]), -on_family[i], i))
    best = []
    for i in order[:verify]:
        policy = champion_policy(Champion(mode=config.mode, fitness=0.0, solved=True, generation=0,
                                          genome=None, controllers=teams[i], seed=config.seed,  # type: ignore[arg-type]
                                          map=config.map, **config.task.team_settings()))
        noisy = task_params("generalization").with_team_settings(config.task)
        row = {"name": names[i], "plus_batch": int(on_plus[i]), "family_batch": int(on_family[i])}
        for m in ("plus", "asymmetric_plus"):
            row[m] = int(sum(sequential(policy, map=m, params=noisy, episodes=10, seed=1)["solved"]))
        best.append(row)
    high = int(0.8 * episodes)
    return {"run": run.name, "pool": len(teams), "best": best,
            "dist": {"plus_ge16": int((on_plus >= high).sum()), "family_ge16": int((on_family >= high).sum()),
                     "both_ge16": int(((on_plus >= high) & (on_family >= high)).sum())}}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("inputs", nargs="+", type=Path, help="run folders, or with --csv the JSON-lines files")
    ap.add_argument("--csv", type=Path, help="write the JSON-lines files' rows as one CSV table")
    args = ap.parse_args()
    if args.csv is None:
        for run in args.inputs:
            print(json.dumps(study(run)), flush=True)
        return
    rows = []
    for path in args.inputs:
        for line in path.read_text().splitlines():
            r = json.loads(line)
            base = {"experiment": path.stem, "run": r["run"], "pool": r["pool"]}
            for rank, x in enumerate(r.get("best", []), 1):
                rows.append({**base, "rank": rank, "team": x["name"], "plus_core_of_20": x["plus_batch"],
                             "family_core_of_20": x["family_batch"], "plus_pymunk_of_10": x["plus"],
                             "asymmetric_plus_pymunk_of_10": x["asymmetric_plus"],
                             "pool_plus_ge16": r["dist"]["plus_ge16"], "pool_family_ge16": r["dist"]["family_ge16"],
                             "pool_both_ge16": r["dist"]["both_ge16"]})
            if not r.get("best"):
                rows.append(base)
    with open(args.csv, "w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=list(max(rows, key=len)))
        writer.writeheader()
        writer.writerows(rows)
    print(f"{len(rows)} rows -> {args.csv}", file=sys.stderr)


if __name__ == "__main__":
    main()
