"""Which part of the generalisation noise breaks a run's pool, on plus and on the run's own variants.

The pool is `selection_study.pool(run)` (the final population's noise-free solvers and the archived solutions).
Each team plays 20 sequential-protocol episodes on plus and one on each of 20 of the run's plus variants in the
compiled core (the selection study's keys), under: the whole generalisation noise, no noise, and each of its five
components alone (sensor, effector, heading, start position, start heading).  Per setting and map: the pool's mean
successes of 20, how many teams succeed in 16 or more, and per episode how many robots reached their post, came
home when called and went back out (of 3).

    python docs/results/selection/noise_parts.py RUN_FOLDER [RUN_FOLDER ...] > noise_parts.csv
"""
from __future__ import annotations

import argparse
import csv
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from selection_study import FAMILY_OFFSET, STUDY_KEY, pool  # noqa: E402

from mahn_envs.core.batch import BatchSim  # noqa: E402
from mahn_envs.core.sequential import S_HOME, S_OUT, S_POST, SequentialSettings, sequential_task  # noqa: E402
from mahn_envs.maps import load_map  # noqa: E402
from mahn_envs.maps.variants import spread_variant  # noqa: E402
from mahn_envs.policies.team_controllers import TeamControllers  # noqa: E402
from mahn_evo.evaluation.noise_parts import noise_part_params  # noqa: E402
from mahn_evo.evaluation.task_setup import task_params  # noqa: E402

FIELDS = ("run", "pool", "noise", "map", "mean_successes_of_20", "teams_ge16", "posts_of_3", "home_of_3", "out_of_3")


def measure(run: Path, episodes: int = 20) -> list[dict]:
    config, teams, _ = pool(run)
    if not teams:
        return []
    ev = config.evaluation
    ctrl = TeamControllers.stack(teams)
    maps = {"plus": ([load_map(config.map)] * episodes, STUDY_KEY),
            "variants": ([spread_variant(config.seed, STUDY_KEY + FAMILY_OFFSET + i, ev.map_spread, ev.map_branch,
                                         ev.branch_sides) for i in range(episodes)], STUDY_KEY + FAMILY_OFFSET)}
    rows = []
    for name, params in noise_part_params(task_params("generalization")).items():
        task = sequential_task(params.with_team_settings(config.task), SequentialSettings())
        for label, (worlds, first_key) in maps.items():
            wins = np.zeros(len(teams))
            stages = np.zeros((len(teams), 3))
            for w, world in enumerate(worlds):
                rec = BatchSim(world, len(teams), task).run_sequential(
                    ctrl, seed=config.seed, episode_keys=np.full(len(teams), first_key + w, dtype=np.int64))
                wins += rec.success
                stages += rec.stages[:, :, [S_POST, S_HOME, S_OUT]].sum(axis=1)
            per_episode = stages.mean(axis=0) / episodes
            rows.append({"run": run.name, "pool": len(teams), "noise": name, "map": label,
                         "mean_successes_of_20": round(float(wins.mean()), 2),
                         "teams_ge16": int((wins >= int(0.8 * episodes)).sum()),
                         "posts_of_3": round(float(per_episode[0]), 2), "home_of_3": round(float(per_episode[1]), 2),
                         "out_of_3": round(float(per_episode[2]), 2)})
    return rows


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("runs", nargs="+", type=Path, help="run folders (a hardened experiment's runs/situational_s0*)")
    args = ap.parse_args()
    writer = csv.DictWriter(sys.stdout, fieldnames=FIELDS)
    writer.writeheader()
    for run in args.runs:
        writer.writerows(measure(run))
        sys.stdout.flush()


if __name__ == "__main__":
    main()
