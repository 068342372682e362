"""The training loop: NEAT (ask/tell) -> CPPN decoding -> batch evaluation, with files a researcher keeps.

Run folder:
  config.json      the resolved EvolutionConfig
  log.csv          one row per generation (fitness, species, solved, evaluations, seconds)
  checkpoint.json  full NEAT state + trainer state after the last finished generation (atomic, with the sha256
                   of its content: a changed digit is refused, not resumed as another run); --resume
                   continues from it bit-identically
  champion.json    best team so far (CPPN + decoded controllers); with robust_from "first_solution", the best
                   team of the robust phase once it has started
  archive/         every solved champion that improved on the last archived one (the generalisation test
                   picks among all solutions a run found); with fitness_memory "lifetime" or "archive", every new
                   leader: the best team by lifetime mean that solved every episode of LIFETIME_MIN_GENERATIONS
                   generations
  summary.json     mode, seed, generations, best_fitness, solved, first_solved_generation, wall time (and, with
                   robust_from "first_solution", robust_from_generation: the first generation scored under noise;
                   with restart_every, restarts: the generations that started from a fresh population)
  fitness.png      the fitness curve

A fresh run refuses a folder that holds another run (--overwrite removes it first); `mahn-evo train` and each
experiment worker hold the folder's lock (storage/folder_lock.py) while they write.
"""
from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ..hyperneat.team_evaluator import TeamEvaluator
from ..neat.genome import Genome
from ..neat.population import Population
from ..storage.files import (
    atomic_write_checked_json,
    atomic_write_csv,
    atomic_write_json,
    read_checked_json,
    read_versioned_json,
    remove_stray_temp_files,
    versioned,
)
from ..storage.folder_lock import check_folder_usable
from .champion import Champion
from .config import STOPPING_RULES, EvolutionConfig, continues_before_robust_phase
from .diversity import selection_fitness
from .lifetime import LIFETIME_MIN_GENERATIONS, LifetimeScores, genome_digest

#: what a run writes into its folder; --overwrite removes exactly these (and archive/)
RUN_FILES = ("config.json", "log.csv", "checkpoint.json", "summary.json", "champion.json", "fitness.png",
             "champion.gif", "champion.png")
RUN_FOLDERS = ("archive",)

LOG_HEADER = ["generation", "evaluations", "best_fitness", "mean_fitness", "best_ever", "solved", "n_solved",
              "n_species", "threshold", "mean_complexity", "seconds"]


@dataclass
class Progress:
    generation: int
    generations: int
    best_fitness: float
    mean_fitness: float
    best_ever: float
    n_species: int
    solved: bool
    first_solved: int | None
    seconds: float


class Trainer:
    """One evolutionary run in a folder.  Create it fresh or with resume=True to continue a checkpoint."""

    def __init__(self, config: EvolutionConfig, out_dir: str | Path, resume: bool = False,
                 overwrite: bool = False) -> None:
        """resume: continue the folder's checkpoint (a run killed before its first checkpoint starts over, the
        same run from the same config).  overwrite: remove the folder's old run first.  A fresh run in a
        folder that holds another run is refused."""
        if resume and overwrite:
            raise ValueError("choose one of --resume (continue the run in the folder) and --overwrite (replace it)")
        self.config = config
        self.out = check_folder_usable(out_dir, "run folder")
        self.evaluator = TeamEvaluator(config.evaluation)
        #: robust_from "first_solution": the noise-free evaluation that scores the generations up to the first
        #: solution (the same run as without noise until then)
        self.noise_free_evaluator = (TeamEvaluator(config.noise_free_evaluation)
                                     if config.robust_from == "first_solution" else None)
        self.rows: list[list] = []
        self._reflex_arc = config.task.reflex_arc  # of the generation being scored (see step)
        self.best_fitness = -np.inf
        self.first_solved: int | None = None
        self.archived_fitness = -np.inf
        self.wall = 0.0
        #: fitness_memory "lifetime" or "archive": the teams' scores over the generations they were scored in
        #: under noise, and the digest of the last leader archived
        self.lifetime = LifetimeScores()
        self.last_archived: str | None = None
        remove_stray_temp_files(self.out)
        ckpt = self.out / "checkpoint.json"
        if resume and not ckpt.exists() and (self.out / "config.json").exists():
            # killed before its first checkpoint: nothing to continue, so the same run starts over
            self._check_same_run(read_versioned_json(self.out / "config.json", "config"))
            overwrite = True
        elif resume:
            self._resume(ckpt)
            return
        old = run_files(self.out)
        if old and not overwrite:
            what = "a run (checkpoint.json)" if ckpt.exists() else f"another run ({', '.join(old)})"
            raise ValueError(f"{str(self.out)!r} already holds {what}; use --resume to continue it, --overwrite "
                             "to replace it, or choose another --out")
        if old:
            clear_run(self.out)
        self.population = Population.create(config.neat, seed=config.seed, kind=config.init,
                                            n_inputs=config.n_cppn_inputs)
        self.out.mkdir(parents=True, exist_ok=True)
        atomic_write_json(self.out / "config.json", versioned("config", config.to_dict()))

    # ------------------------------------------------------------------ checkpoint
    def _check_same_run(self, saved_config: dict, generation: int = 0, first_solved: int | None = None) -> None:
        """The configuration a folder's run was made with must be the one asked for, but for STOPPING_RULES; or the
        asked one adds (or changes) a robust phase that has not started by `generation`, the next generation to
        run (`continues_before_robust_phase`: the resumed run is then the fresh run of the asked configuration)."""
        # the values it was run with: keys added since keep their defaults, changed defaults their old values
        saved_cfg = EvolutionConfig.from_saved(saved_config)
        saved, asked = saved_cfg.to_dict(), self.config.to_dict()
        differing = sorted(k for k in asked if k not in STOPPING_RULES and saved[k] != asked[k])
        if differing and continues_before_robust_phase(saved_cfg, self.config):
            starts = [c.robust_phase_start(first_solved) for c in (saved_cfg, self.config)
                      if c.robust_from == "first_solution"]
            begun = [s for s in starts if s is not None and s < generation]
            if not begun:
                differing = []
            else:
                raise ValueError(f"cannot resume {str(self.out)!r} with another robust phase: the run has scored "
                                 f"generations up to {generation - 1}, and a robust phase starting at generation "
                                 f"{min(begun)} would have scored some of them (a robust phase may be added or "
                                 "changed only before it starts: give a longer robust_delay or start a new run)")
        if "neat" in differing:  # name the NEAT settings, so the message says what to set
            differing.remove("neat")
            differing += sorted(f"neat.{k}" for k in set(asked["neat"]) | set(saved["neat"])
                                if saved["neat"].get(k) != asked["neat"].get(k))
        if differing:
            raise ValueError(f"cannot resume {str(self.out)!r}: configuration differs in {differing} "
                             f"(only the stopping rules {list(STOPPING_RULES)} may change on resume, and a robust "
                             "phase that has not started; the run was made with "
                             f"{_saved_values(saved, differing)})")
        if saved != asked:
            atomic_write_json(self.out / "config.json", versioned("config", asked))

    def _resume(self, ckpt: Path) -> None:
        data = read_checked_json(ckpt, "checkpoint")
        where = f"checkpoint file {str(ckpt)!r} is malformed"
        try:
            if not isinstance(data.get("config"), dict):
                raise KeyError("config")
            generation, first_solved = data["population"]["generation"], data["trainer"]["first_solved"]
            if not isinstance(generation, int) or not (first_solved is None or isinstance(first_solved, int)):
                raise TypeError("'generation' and 'first_solved' must be whole numbers")
            self._check_same_run(data["config"], generation, first_solved)
        except (KeyError, TypeError, AttributeError, IndexError) as exc:
            raise ValueError(f"{where}: missing or wrong field {exc}") from exc
        try:
            self.population = Population.from_dict(data["population"])
            t = data["trainer"]
            self.best_fitness = -np.inf if t["best_fitness"] is None else float(t["best_fitness"])
            self.first_solved = None if t["first_solved"] is None else int(t["first_solved"])
            self.archived_fitness = -np.inf if t["archived_fitness"] is None else float(t["archived_fitness"])
            self.wall = float(t["wall_seconds"])
            self.rows = t["log"]
            self.last_archived = t.get("last_archived")
            if self.last_archived is not None and not isinstance(self.last_archived, str):
                raise TypeError("'last_archived' must be a genome digest (text) or null")
            if t.get("lifetime") is not None:
                self.lifetime = LifetimeScores.from_list(self.population.genomes, t["lifetime"])
            if not isinstance(self.rows, list) or not all(isinstance(r, list) and len(r) == len(LOG_HEADER)
                                                          for r in self.rows):
                raise TypeError(f"'log' must hold rows of {len(LOG_HEADER)} values ({', '.join(LOG_HEADER)})")
        except (KeyError, TypeError, ValueError, AttributeError, IndexError) as exc:
            raise ValueError(f"{where}: missing or wrong field {exc}") from exc
        state = self.population.settings.to_dict()
        asked = self.config.neat.to_dict()
        differing = sorted(k for k in set(state) | set(asked) if state.get(k) != asked.get(k))
        if differing:
            raise ValueError(f"cannot resume {str(self.out)!r}: the population in checkpoint.json was bred with "
                             f"other NEAT settings than its configuration says ({differing}: "
                             f"{', '.join(f'{k} = {state.get(k)!r}' for k in differing)} in the state); the file "
                             "was edited by hand")

    def _checkpoint(self) -> None:
        state = {"config": self.config.to_dict(), "population": self.population.to_dict(), "trainer": {
            "best_fitness": None if not np.isfinite(self.best_fitness) else self.best_fitness,
            "first_solved": self.first_solved,
            "archived_fitness": None if not np.isfinite(self.archived_fitness) else self.archived_fitness,
            "wall_seconds": self.wall, "log": self.rows}}
        if self.config.fitness_memory != "generation":
            state["trainer"]["lifetime"] = self.lifetime.to_list(self.population.genomes)
            state["trainer"]["last_archived"] = self.last_archived
        atomic_write_checked_json(self.out / "checkpoint.json", "checkpoint", state)

    # ------------------------------------------------------------------ loop
    @property
    def generation(self) -> int:
        return self.population.generation

    def step(self) -> Progress:
        """Evaluate the current generation, record it, and breed the next."""
        t0 = time.perf_counter()
        cfg = self.config
        if cfg.restart_due(self.population.generation, self.first_solved):
            self._restart()
        genomes = self.population.ask()
        gen = self.population.generation
        evaluator, episodes = self.evaluator, cfg.episodes
        if self.noise_free_evaluator is not None:
            start = cfg.robust_phase_start(self.first_solved)
            if start is None or gen < start:
                evaluator, episodes = self.noise_free_evaluator, self.noise_free_evaluator.settings.episodes
            elif gen == start:
                # the robust phase starts: its champion and archive are the best teams under the robust evaluation
                # (noise-free scores are not comparable with aggregated noisy ones)
                self.best_fitness = self.archived_fitness = -np.inf
        ev = evaluator.evaluate(genomes, gen)
        # a champion records the reflex it was scored with (reflex_arc_from "robust_phase" switches it)
        self._reflex_arc = evaluator.settings.task.reflex_arc
        order = np.argsort(-ev.fitness, kind="stable")
        best = int(order[0])
        solved_mask = ev.solved >= 1.0
        self._record_best(gen, genomes, ev, best)
        if solved_mask.any() and self.first_solved is None:
            self.first_solved = gen
        fitness = ev.fitness
        if cfg.fitness_memory != "generation" and evaluator is self.evaluator:
            mean = self._archive_lifetime_leader(gen, genomes, ev, solved_mask)
            if cfg.fitness_memory == "lifetime":
                fitness = mean
        else:
            self._archive_record(gen, genomes, ev, order, solved_mask)
        stats = self.population.tell(selection_fitness(fitness, ev.end_positions, cfg.diversity, cfg.diversity_k))
        seconds = time.perf_counter() - t0
        self.wall += seconds
        # team-episodes: the keyed training episodes, the noise-free variant ones and the sequential-protocol ones
        # (each of those is longer), for every reading: the nominal budget, also where symmetry "best" stops a
        # reading's sequential episodes early because it cannot be its genome's best (TeamEvaluator._best_outcomes)
        played = episodes + evaluator.settings.noise_free_variants + evaluator.settings.sequential_episodes
        evaluations = (self.rows[-1][1] if self.rows else 0) + len(genomes) * played * evaluator.readings
        self.rows.append([gen, evaluations, float(ev.fitness[best]), float(ev.fitness.mean()),
                          float(self.best_fitness), bool(solved_mask[best]), int(solved_mask.sum()),
                          stats.n_species, round(stats.threshold, 6), round(stats.mean_complexity, 3),
                          round(seconds, 4)])
        if (gen + 1) % cfg.checkpoint_every == 0:
            self._write_log()
            self._checkpoint()
        return Progress(gen, cfg.generations, float(ev.fitness[best]), float(ev.fitness.mean()),
                        float(self.best_fitness), stats.n_species, bool(solved_mask[best]), self.first_solved,
                        seconds)

    def _restart(self) -> None:
        """A fresh initial population for the current generation (restart_every); the champion, the log and the
        generation count carry on."""
        gen = self.population.generation
        cfg = self.config
        self.population = Population.create(cfg.neat, seed=cfg.restart_seed(gen), kind=cfg.init,
                                            n_inputs=cfg.n_cppn_inputs)
        self.population.generation = gen

    def _archive_record(self, gen: int, genomes: list[Genome], ev, order: np.ndarray, solved_mask: np.ndarray) -> None:
        """The default archive: the generation's best solved team when it beats the last one archived."""
        if not solved_mask.any():
            return
        s_best = int(order[np.argmax(solved_mask[order])])
        if ev.fitness[s_best] > self.archived_fitness:
            self.archived_fitness = float(ev.fitness[s_best])
            self._champion(gen, genomes[s_best], ev, s_best).save(
                self.out / "archive" / f"solution_g{gen:05d}_i{s_best:04d}.json")

    def _archive_lifetime_leader(self, gen: int, genomes: list[Genome], ev, solved_mask: np.ndarray) -> np.ndarray:
        """fitness_memory "lifetime" or "archive": record this generation's scores, archive the leader when it is
        a new team, and return the lifetime means (what NEAT selects by with "lifetime"; mahn_evo.training.lifetime)."""
        mean, scored, all_solved = self.lifetime.update(genomes, ev.fitness, solved_mask)
        eligible = np.flatnonzero(all_solved & (scored >= LIFETIME_MIN_GENERATIONS))
        if len(eligible):
            leader = int(eligible[np.argmax(mean[eligible])])
            digest = genome_digest(genomes[leader])
            if digest != self.last_archived:
                self.last_archived = digest
                self._champion(gen, genomes[leader], ev, leader, fitness=float(mean[leader])).save(
                    self.out / "archive" / f"solution_g{gen:05d}_i{leader:04d}.json")
        return mean

    def _champion(self, gen: int, genome: Genome, ev, index: int, fitness: float | None = None) -> Champion:
        """The team `index` of a generation; `fitness` (default: its score in this generation) is what it records."""
        return Champion(mode=self.config.mode, fitness=float(ev.fitness[index]) if fitness is None else fitness,
                        solved=bool(ev.solved[index] >= 1),
                        generation=gen, genome=genome, controllers=ev.controllers.team(index),
                        seed=self.config.seed, map=self.config.map, reflex_arc=self._reflex_arc,
                        input_ceiling=self.config.task.input_ceiling)

    def _record_best(self, gen: int, genomes, ev, best: int) -> None:
        if ev.fitness[best] > self.best_fitness:
            self.best_fitness = float(ev.fitness[best])
            self._champion(gen, genomes[best], ev, best).save(self.out / "champion.json")

    def _write_log(self) -> None:
        atomic_write_csv(self.out / "log.csv", LOG_HEADER, self.rows)

    def done(self) -> bool:
        if self.generation >= self.config.generations:
            return True
        return self.config.stop_when_solved and self.first_solved is not None and \
            self.generation > self.first_solved + self.config.after_solved

    def run(self, on_generation: Callable[[Progress], None] | None = None) -> dict:
        while not self.done():
            p = self.step()
            if on_generation is not None:
                on_generation(p)
        return self.finish()

    def finish(self) -> dict:
        """Write the log, checkpoint, summary and fitness plot for what has been run so far."""
        self._write_log()
        self._checkpoint()
        pop = self.config.neat.reproduction.population_size
        summary = {"mode": self.config.mode, "seed": self.config.seed, "init": self.config.init,
                   "map": self.config.map, "generations": self.generation,
                   "population": pop,
                   "best_fitness": None if not np.isfinite(self.best_fitness) else self.best_fitness,
                   "solved": self.first_solved is not None, "first_solved_generation": self.first_solved,
                   "evaluations": self.rows[-1][1] if self.rows else 0, "wall_seconds": round(self.wall, 3)}
        if self.config.restart_every:
            summary["restarts"] = [g for g in range(self.config.restart_every, self.generation,
                                                    self.config.restart_every)
                                   if self.first_solved is None or g <= self.first_solved]
        if self.config.robust_from == "first_solution":
            summary["robust_from_generation"] = self.config.robust_phase_start(self.first_solved)
        atomic_write_json(self.out / "summary.json", summary)
        from ..plots import fitness_curve

        fitness_curve(self.out / "log.csv", self.out / "fitness.png",
                      title=f"{self.config.mode}, seed {self.config.seed}, pop {pop}")
        return summary


def run_files(folder: Path) -> list[str]:
    """The files and folders of a run that `folder` holds."""
    return [name for name in RUN_FILES + RUN_FOLDERS if (folder / name).exists()]


def clear_run(folder: Path) -> None:
    """Remove a run's files (nothing else a user keeps in the folder)."""
    import shutil

    for name in RUN_FILES:
        (folder / name).unlink(missing_ok=True)
    for name in RUN_FOLDERS:
        if (folder / name).is_dir():
            shutil.rmtree(folder / name)


def _saved_values(saved: dict[str, Any], keys: list[str]) -> str:
    vals = [f"{k} = {saved['neat'].get(k[5:]) if k.startswith('neat.') else saved.get(k)!r}" for k in keys]
    return ", ".join(vals)


def train(config: EvolutionConfig, out_dir: str | Path, resume: bool = False,
          on_generation: Callable[[Progress], None] | None = None, overwrite: bool = False) -> dict:
    """Python API of `mahn-evo train`: run (or continue, or replace) a run and return its summary."""
    return Trainer(config, out_dir, resume=resume, overwrite=overwrite).run(on_generation)
