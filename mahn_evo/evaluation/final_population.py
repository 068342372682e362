"""Final validation: every team of a run's last population scored on fresh noisy episodes, the best archived.

Why: the archive keeps teams by what one generation's few episodes said about them (a new record, or with
`fitness_memory` a team that solved every episode of 3 generations), and a robust phase can end with its most
reliable teams unarchived: a team that appeared late, or failed one episode of its three.  On the lifetime
hardening of seeds 1-15 (docs/results/experiment_lifetime_seeds_1_15/) no robust-phase team was archived at all,
while the final populations held teams solving up to 96 % of the 25 generalisation episodes.  Scoring the whole
final population (every reading, with `--symmetry best`) on its own validation episodes and archiving the best
noise-free solution among them is the standard post-evaluation of evolutionary robotics: cheap (a few seconds
per run) and blind to the report's test episodes.

The validation episodes use the run's own noise preset (the generalisation noise for runs evolved without noise or
with it; the robot noise for runs evolved with `--noise robot`), with the run's seed and keys from VALIDATION_KEY on:
never a training episode's key (generation * K + e) nor the generalisation test's (0, 1, ... with seed 0).  The chosen
team must solve the noise-free task on the run's map (it is archived as a solution); among those, the most
episodes solved, then the best mean fitness, then the lowest population index and reading wins.
"""
from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from mahn_envs.core.batch import BatchSim
from mahn_envs.core.sequential import SequentialSettings, sequential_task
from mahn_envs.maps import World, load_map
from mahn_envs.maps.variants import spread_variant
from mahn_envs.policies.team_controllers import TeamControllers

from ..hyperneat.substrate import READINGS, team_reading
from ..hyperneat.team_evaluator import CONTROLLER_FIELDS, TeamEvaluator
from ..neat.population import Population
from ..storage.files import atomic_write_json, read_checked_json, read_versioned_json, versioned
from ..training.champion import Champion
from ..training.config import EvolutionConfig
from .eval_champion import champion_policy
from .generalize import keyed_episodes
from .protocols import sequential, sequential_episode
from .task_setup import TEST_NOISES, task_params

#: the first validation episode's key (training keys are generation * K + e, far below)
VALIDATION_KEY = 1 << 40
#: the first seed of the sequential stage's episodes (the transfer test's are the experiment's seed + 0, 1, ...)
SEQUENTIAL_SEED = 1 << 30
#: the first key of the family stage's plus variants (`spread_variant(seed, key, ...)`): above the validation keys,
#: far from the training episodes' (generation x episodes) and the sequential ones' (2**31 + ...)
FAMILY_KEY = 1 << 41
#: the first seed of the family stage's sequential episodes (beside the sequential stage's SEQUENTIAL_SEED + e)
FAMILY_SEED = SEQUENTIAL_SEED + (1 << 20)
#: engine "batch": the first episode key of the sequential stage's episodes on the map, with the run's seed (below
#: 2**32, as start jitter reads a key's low 32 bits; above the training's sequential and noise-free variant keys)
BATCH_SEQUENTIAL_KEY = 7 << 29
#: engine "batch": the first episode key of the family stage's episodes (their maps are FAMILY_KEY + i's variants)
BATCH_FAMILY_KEY = BATCH_SEQUENTIAL_KEY + (1 << 20)
#: where the sequential stage plays its episodes: "pymunk" (the transfer test's engine: robots bump into each
#: other) or "batch" (the compiled core's protocol, as training plays it: about 50 times faster, so the stage can
#: afford every candidate and more episodes; its successes track pymunk's, docs/results/selection/)
ENGINES = ("pymunk", "batch")
KIND = "final_validation"


def validation_noise(config: EvolutionConfig) -> str:
    """The noise preset a run's validation uses: its own, when it was evolved with a named one other than none (a
    team hardened for robots is chosen under the noise it was hardened for), else the generalisation test's."""
    own = config.noise_preset
    return own if own not in (None, "none") else "generalization"


def final_population(run_dir: str | Path) -> tuple[EvolutionConfig, Population]:
    """A run folder's configuration and the population of its last checkpoint (the generation it would play
    next: the last generation's elites and their offspring)."""
    run = Path(run_dir)
    if not (run / "checkpoint.json").is_file():
        raise ValueError(f"run folder {str(run)!r} has no checkpoint.json to take the final population from")
    config = EvolutionConfig.from_saved(read_versioned_json(run / "config.json", "config"))
    data = read_checked_json(run / "checkpoint.json", "checkpoint")
    try:
        population = Population.from_dict(data["population"])
    except (KeyError, TypeError, ValueError) as exc:
        raise ValueError(f"checkpoint file {str(run / 'checkpoint.json')!r} is malformed: {exc}") from exc
    return config, population


def validate_final_population(run_dir: str | Path, episodes: int = 25, sequential_teams: int = 0,
                              sequential_episodes: int = 10, family_episodes: int = 0, engine: str = "pymunk",
                              write: bool = True, noise: str | None = None) -> dict[str, Any]:
    """Score every team of the run's final population (every reading with symmetry "best") on `episodes` noisy
    validation episodes; with `sequential_teams` T > 0, play the T best noise-free solutions of that ranking
    through `sequential_episodes` noisy episodes of the sequential protocol on the run's map and choose by those;
    with `family_episodes` F > 0 (a run trained on plus variants), each of them also plays F such episodes on
    the run's own variants (keys from FAMILY_KEY, never trained on) and the choice counts both; `engine` says where
    those episodes run (ENGINES); `noise` is their noise preset (default `validation_noise` of the run).  Why: a
    team's
    successes on its training family predict the test map, where its successes on the map itself do not
    (docs/results/turn_probes/: picks with 8-10 of 10 on plus and 0-1 on the test map all score 0-1 on the family).
    With `write`, archive the chosen team as archive/solution_final_gGGGGG_iIIII.json (replacing the pick of an
    earlier validation of the same generation) and record the ranking in final_validation.json.  Returns that
    record ("chosen" is None when no team of the population solves the noise-free task)."""
    for name, v in (("episodes", episodes), ("sequential_episodes", sequential_episodes)):
        if isinstance(v, bool) or not isinstance(v, int) or v < 1:
            raise ValueError(f"{name} must be a positive integer, got {v!r}")
    if isinstance(sequential_teams, bool) or not isinstance(sequential_teams, int) or sequential_teams < 0:
        raise ValueError(f"sequential_teams must be a non-negative integer, got {sequential_teams!r}")
    if isinstance(family_episodes, bool) or not isinstance(family_episodes, int) or family_episodes < 0:
        raise ValueError(f"family_episodes must be a non-negative integer, got {family_episodes!r}")
    if engine not in ENGINES:
        raise ValueError(f"engine must be one of {ENGINES}, got {engine!r}")
    if family_episodes and not sequential_teams:
        raise ValueError("family_episodes plays the sequential stage's teams on the run's plus variants: give "
                         "sequential_teams (--sequential T) too")
    run = Path(run_dir)
    config, population = final_population(run)
    noise = validation_noise(config) if noise is None else noise
    if noise not in TEST_NOISES:
        raise ValueError(f"noise must be a noise preset other than 'none' {TEST_NOISES}, got {noise!r}")
    ev = config.evaluation
    if family_episodes and not ev.on_variants:
        raise ValueError(f"run {str(run)!r} trained on its map alone (no --map-spread or --map-branch): it has no "
                         "family of plus variants to validate on (family_episodes)")
    genomes = population.genomes
    controllers = TeamEvaluator(ev).decode(genomes)
    readings = READINGS if config.symmetry == "best" else ("none",)
    team = config.task.team_settings()
    clean = config.task.without_noise()
    noisy = task_params(noise).with_team_settings(team)
    keys = [VALIDATION_KEY + i for i in range(episodes)]
    rows: list[dict[str, Any]] = []
    batches = {reading: team_reading(controllers, reading) for reading in readings}
    # every reading in one batch: readings share robots, which then play once per episode (keyed_episodes)
    w_ih, w_hh, w_ho, b_h, b_o = (np.concatenate([getattr(batches[reading], f) for reading in readings])
                                  for f in CONTROLLER_FIELDS)
    every = TeamControllers(w_ih, w_hh, w_ho, b_h, b_o, controllers.decision)
    all_clean_fit, all_clean_solved = keyed_episodes(every, config.map, clean, config.seed, [0])
    all_fit, all_solved = keyed_episodes(every, config.map, noisy, config.seed, keys)
    for a, reading in enumerate(readings):
        for i in range(len(genomes)):
            k = a * len(genomes) + i
            rows.append({"index": i, "reading": reading, "noise_free_fitness": float(all_clean_fit[k, 0]),
                         "noise_free_solved": bool(all_clean_solved[k, 0]),
                         "solved_fraction": float(all_solved[k].mean()), "mean_fitness": float(all_fit[k].mean())})
    rows.sort(key=lambda r: (not r["noise_free_solved"], -r["solved_fraction"], -r["mean_fitness"], r["index"],
                             readings.index(r["reading"])))
    gen = population.generation

    def champion(row: dict[str, Any]) -> Champion:
        return Champion(mode=config.mode, fitness=row["mean_fitness"], solved=True, generation=gen,
                        genome=genomes[row["index"]], controllers=batches[row["reading"]].team(row["index"]),
                        seed=config.seed, map=config.map, **team)

    record: dict[str, Any] = {"generation": gen, "episodes": episodes, "seed": config.seed,
                              "first_key": VALIDATION_KEY, "noise": noise, "teams": len(rows),
                              "chosen": None, "top": rows[:10]}
    candidates = [r for r in rows if r["noise_free_solved"]]
    if sequential_teams:
        candidates = candidates[:sequential_teams]
        worlds = [spread_variant(config.seed, FAMILY_KEY + i, ev.map_spread, ev.map_branch, ev.branch_sides)
                  for i in range(family_episodes)]
        if engine == "batch":
            _batch_sequential_stage(candidates, [champion(r).controllers for r in candidates], config, worlds,
                                    sequential_episodes, noise)
        for row in candidates if engine == "pymunk" else ():
            champ = champion(row)
            policy, params = champion_policy(champ), champ.task(task_params(noise))
            result = sequential(policy, map=config.map, params=params, episodes=sequential_episodes,
                                seed=SEQUENTIAL_SEED)
            row["sequential_successes"] = int(sum(result["solved"]))
            row["sequential_stages"] = float(sum(result["fitness"]) / sequential_episodes)
            if family_episodes:
                family = [sequential_episode(policy, world, params, seed=FAMILY_SEED + i)
                          for i, world in enumerate(worlds)]
                row["family_successes"] = sum(int(f.success) for f in family)
                row["family_stages"] = float(sum(f.score for f in family) / family_episodes)

        def choice(r: dict[str, Any]) -> tuple[float, float]:
            if not family_episodes:
                return -r["sequential_successes"], -r["sequential_stages"]
            return (-(r["sequential_successes"] + r["family_successes"]),
                    -(r["sequential_stages"] * sequential_episodes + r["family_stages"] * family_episodes))
        candidates.sort(key=choice)  # stable: then the rows' order
        in_core = engine == "batch"
        record["sequential"] = {"teams": sequential_teams, "episodes": sequential_episodes, "engine": engine,
                                **({"first_key": BATCH_SEQUENTIAL_KEY} if in_core else {"first_seed": SEQUENTIAL_SEED}),
                                "map": config.map, "noise": noise, "ranking": candidates}
        if family_episodes:
            record["sequential"]["family"] = {
                "episodes": family_episodes, "first_key": FAMILY_KEY,
                **({"first_episode_key": BATCH_FAMILY_KEY} if in_core else {"first_seed": FAMILY_SEED}),
                "maps": [w.name for w in worlds]}
    best = candidates[0] if candidates else None
    pick = None if best is None else f"solution_final_g{gen:05d}_i{best['index']:04d}.json"
    if best is not None and pick is not None:
        record["chosen"] = {**best, "file": f"archive/{pick}"}
        if write:
            champion(best).save(run / "archive" / pick)
    if write:
        atomic_write_json(run / "final_validation.json", versioned(KIND, record))
        # a pick of an earlier validation of this same population (other settings) leaves the archive: it would
        # otherwise compete with this one in the generalisation ranking the report draws its teams from
        for old in (run / "archive").glob(f"solution_final_g{gen:05d}_i*.json"):
            if old.name != pick:
                old.unlink()
    return record


def _batch_sequential_stage(rows: list[dict[str, Any]], teams: list[TeamControllers], config: EvolutionConfig,
                            worlds: list[World], episodes: int, noise: str = "generalization") -> None:
    """The sequential stage in the compiled core: every candidate plays `episodes` noisy protocol episodes on the
    run's map (keys BATCH_SEQUENTIAL_KEY + e) and one on each family world (keys BATCH_FAMILY_KEY + i), all
    candidates of an episode in one batch; writes the counts into `rows` as the pymunk stage does."""
    if not rows:
        return
    task = sequential_task(task_params(noise).with_team_settings(config.task), SequentialSettings())
    ctrl = TeamControllers.stack(teams)
    n, stages = len(rows), 3 * ctrl.n_robots
    plays = [(load_map(config.map), BATCH_SEQUENTIAL_KEY + e, "sequential") for e in range(episodes)]
    plays += [(world, BATCH_FAMILY_KEY + i, "family") for i, world in enumerate(worlds)]
    counts = {k: (np.zeros(n, dtype=np.int64), np.zeros(n)) for k in ("sequential", "family")}
    for world, key, stage in plays:
        rec = BatchSim(world, n, task).run_sequential(ctrl, seed=config.seed,
                                                      episode_keys=np.full(n, key, dtype=np.int64))
        counts[stage][0][:] += rec.success
        counts[stage][1][:] += rec.stages_completed / stages
    for j, row in enumerate(rows):
        row["sequential_successes"] = int(counts["sequential"][0][j])
        row["sequential_stages"] = float(counts["sequential"][1][j] / episodes)
        if worlds:
            row["family_successes"] = int(counts["family"][0][j])
            row["family_stages"] = float(counts["family"][1][j] / len(worlds))
