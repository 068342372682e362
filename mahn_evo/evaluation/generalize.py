"""The paper's generalisation test: score every archived solution of a run under noise and rank them.

Each solution plays `episodes` (default 25) keyed episodes on the plus map with sensor noise, stochastic turning
and locomotion, and small start perturbations (the `generalization` noise preset); every solution sees the same
noise realisations (common random numbers), so the ranking compares teams, not luck.  The most general
solution of a run is the top row.
"""
from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from mahn_envs.core import BatchSim, TaskParams
from mahn_envs.policies.team_controllers import TeamControllers

from ..hyperneat.team_evaluator import all_robots_mask, robot_episodes
from ..storage.files import atomic_write_csv, atomic_write_json, versioned
from ..training.champion import Champion
from .task_setup import task_params


def solutions_of(run_dir: str | Path) -> list[Path]:
    """Archived solutions of a run (falls back to the champion when the archive is empty)."""
    run = Path(run_dir)
    if not run.is_dir():
        raise ValueError(f"run folder {str(run)!r} does not exist")
    files = sorted((run / "archive").glob("solution_*.json")) if (run / "archive").is_dir() else []
    if not files and (run / "champion.json").exists():
        files = [run / "champion.json"]
    if not files:
        raise ValueError(f"run folder {str(run)!r} has no archive/ solutions and no champion.json")
    return files


def keyed_episodes(teams: TeamControllers, map: str, params: TaskParams, seed: int, keys: Sequence[int]
                   ) -> tuple[np.ndarray, np.ndarray]:
    """Fitness and solved, each (teams, len(keys)), of every team on the same keyed episodes (common random
    numbers: team i's episode j is the same noise draw for every team), in one batch.  Teams that share robots at
    the same places (a population's mirror readings) and are blind to each other play each shared robot once per
    key (robot episodes, `BatchSim.score_teams`: the same numbers)."""
    n, k = teams.w_ih.shape[0], len(keys)
    if not params.robots_see_each_other:
        carriers, robots, src = robot_episodes(teams)
        if len(carriers) < n or np.any(robots != all_robots_mask(teams.n_robots)):
            sim = BatchSim(map, len(carriers) * k, params)
            played = sim.run_robot_episodes(teams.map_arrays(lambda a: np.ascontiguousarray(a[np.repeat(carriers, k)])),
                                            np.repeat(robots, k), seed=seed,
                                            episode_keys=np.tile(np.asarray(keys, dtype=np.int64), len(carriers)))
            # team t's episode j: its robot r from episode src[t, r] * k + j (carrier-major, keys within)
            team_src = (src[:, None, :] * k + np.arange(k)[None, :, None]).reshape(n * k, teams.n_robots)
            fit, ok, _ = sim.score_teams(played, team_src)
            return fit.reshape(n, k), ok.reshape(n, k)
    sim = BatchSim(map, n * k, params)
    res = sim.run_controllers(teams.map_arrays(lambda a: np.repeat(a, k, axis=0)), seed=seed,
                              episode_keys=np.tile(np.asarray(keys, dtype=np.int64), n))
    return res.fitness.reshape(n, k), res.solved.reshape(n, k)


def generalize(run_dir: str | Path, episodes: int = 25, map: str = "plus", params: TaskParams | None = None,
               seed: int = 0, write: bool = True) -> list[dict[str, Any]]:
    """Rank a run's solutions by mean fitness under noise; writes generalization.json/.csv in the run folder."""
    files = solutions_of(run_dir)
    params = params if params is not None else task_params("generalization")
    champs = [Champion.load(f) for f in files]
    modes = {c.mode for c in champs}
    if len(modes) != 1:
        raise ValueError(f"solutions of one run must share a mode, found {sorted(modes)}")
    n = len(champs)
    fit, solved = np.zeros((n, episodes)), np.zeros((n, episodes), dtype=bool)
    # each solution is driven with the team settings it was scored with (a run with reflex_arc_from
    # "robust_phase" has both reflexes); the same episode keys for every solution, so the ranking compares teams on
    # the same noise
    for settings in sorted({tuple(c.team_settings().values()) for c in champs}):
        idx = [i for i, c in enumerate(champs) if tuple(c.team_settings().values()) == settings]
        teams = TeamControllers.stack([champs[i].controllers for i in idx])
        fit[idx], solved[idx] = keyed_episodes(teams, map, champs[idx[0]].task(params), seed, range(episodes))
    rows: list[dict[str, Any]] = []
    for i, (f, c) in enumerate(zip(files, champs)):
        rows.append({"file": f.name, "generation": c.generation, **c.team_settings(),
                     "training_fitness": c.fitness,
                     "mean_fitness": float(fit[i].mean()), "std_fitness": float(fit[i].std()),
                     "solved_fraction": float(solved[i].mean())})
    rows.sort(key=lambda r: (-r["solved_fraction"], -r["mean_fitness"], r["generation"]))
    for rank, r in enumerate(rows, 1):
        r["rank"] = rank
    if write:
        run = Path(run_dir)
        atomic_write_json(run / "generalization.json", versioned("generalization", {
            "map": map, "episodes": episodes, "seed": seed, "params": params.to_dict(), "ranking": rows}))
        header = ["rank", "file", "generation", "training_fitness", "mean_fitness", "std_fitness", "solved_fraction"]
        atomic_write_csv(run / "generalization.csv", header, [[r[h] for h in header] for r in rows])
    return rows
