"""What an experiment is: which modes, how many seeded runs, at what scale, and where each run lives.

The plan is saved as `experiment.json` in the experiment folder.  Re-running the command with the same plan
resumes: finished runs are kept, interrupted runs continue from their checkpoints, missing runs start.  A plan
that differs from the saved one is refused (naming the fields), because mixing runs of two plans would make
the table meaningless.
"""
from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field, fields, replace
from pathlib import Path
from typing import Any

from mahn_envs.core.rng import check_seed

from ..evaluation.final_population import ENGINES
from ..evaluation.task_setup import TEST_NOISES
from ..hyperneat.substrate import MODES
from ..neat.settings import NeatSettings
from ..storage.files import atomic_write_json, read_versioned_json, versioned
from ..storage.migrate import V1_CHANGED_NEAT_DEFAULTS
from ..training.config import INITS, EvolutionConfig, continues_before_robust_phase

PLAN_FILE = "experiment.json"

#: the plan's fields that are EvolutionConfig fields of the same name, passed to every run as they are
EVOLUTION_FIELDS = ("init", "evaluate_modules", "cppn_activation", "decision", "symmetry", "episodes", "noise_draws",
                    "aggregate", "quantile", "noise_free_episode", "map_spread", "map_branch", "branch_sides",
                    "plain_episodes", "sequential_episodes", "sequential_plain", "noise_free_variants",
                    "robust_from", "robust_delay", "noise_free_branch", "fitness_memory", "diversity", "diversity_k",
                    "restart_every", "map", "after_solved")

#: the report's options: they choose what is tested after the runs, so they may change in an experiment's folder
REPORT_OPTIONS = ("top", "general_episodes", "transfer_episodes", "final_validation", "final_sequential",
                  "final_family", "final_engine", "general_from", "general_rank", "transfer_noise")
#: where each run's team for the generalisation ranking comes from: "archive" (its most general archived solution)
#: or "final_validation" (the final validation's pick, when it made one)
GENERAL_FROM = ("archive", "final_validation")
#: how the runs' teams are ranked for "the most general": "generalization" (the paper's test: noisy training episodes
#: on the map) or "protocol" (with general_from "final_validation" and final_sequential: the final validation's
#: successes in noisy sequential episodes on the map and its plus variants, the generalisation test breaking ties).
#: Both use the training family only, never the test map.  Why "protocol": in rob1000 (docs/results/
#: experiment_hardened_sequential/) the generalisation test ranked a run whose teams fail its plus variants third,
#: while 4 of the 5 runs whose picks had 25 or more of their 30 validation successes pass the noisy protocol on both
#: maps, and none of the 9 below
GENERAL_RANKS = ("generalization", "protocol")
#: the noise presets a report's transfer tests can use (every preset with noise)
TRANSFER_NOISES = TEST_NOISES


@dataclass(frozen=True)
class ExperimentPlan:
    modes: tuple[str, ...] = ("situational", "standard")
    runs: int = 15
    seed: int = 1  # run i of every mode uses seed + i (paired seeds across modes)
    generations: int = 1000
    population: int = 500
    init: str = "iros2011"  # the trainer's defaults (see EvolutionConfig)
    evaluate_modules: bool = True
    cppn_activation: str = "recursive"
    decision: str = "output"
    symmetry: str = "none"  # "mirror": bilateral symmetry by construction (see EvolutionConfig)
    #: robust evaluation (see EvolutionConfig): a task noise preset, episodes per team, their draws and aggregation
    noise: str = "none"
    episodes: int = 1
    noise_draws: str = "fixed"
    aggregate: str = "mean"
    quantile: float = 0.25
    noise_free_episode: bool = False
    map_spread: float = 0.0  # keyed episodes on plus variants, arm lengths x [1 - S, 1 + S] (see EvolutionConfig)
    map_branch: float = 0.0  # and side arms leaving the top arm [0, B] cm above the crossing (see EvolutionConfig)
    branch_sides: str = "both"  # or "one" / "one_short": a side at the crossing, the other above it (EvolutionConfig)
    plain_episodes: int = 0  # of which the first N per generation on the map itself (see EvolutionConfig)
    sequential_episodes: int = 0  # sequential-protocol episodes per team per generation (see EvolutionConfig)
    sequential_plain: int = 0  # of which the first P per generation on the map itself (see EvolutionConfig)
    noise_free_variants: int = 0  # noise-free episodes on plus variants per team per generation (EvolutionConfig)
    #: "start" or "first_solution": robust evaluation from the first generation, or only after the first solution
    robust_from: str = "start"
    robust_delay: int = 0  # with robust_from "first_solution": noise-free generations after it first
    noise_free_branch: float = 0.0  # and the noise-free phase also on a branch variant of plus (EvolutionConfig)
    fitness_memory: str = "generation"  # "lifetime" / "archive": scores averaged over generations (EvolutionConfig)
    #: behavioural-diversity selection (see EvolutionConfig.diversity): 0 selects by fitness alone
    diversity: float = 0.0
    diversity_k: int = 15
    restart_every: int = 0  # a fresh population every G generations until the first solution (EvolutionConfig)
    map: str = "plus"
    after_solved: int = 50  # generations kept after the first solution, for the generalisation test
    top: int = 5  # most general solutions (from distinct runs) per mode that get the transfer tests
    general_episodes: int = 25  # noisy episodes of the generalisation test
    transfer_episodes: int = 10  # noisy episodes per transfer test
    #: validation episodes of `mahn-evo final-validation` for every finished run before the report (0: none): the
    #: best noise-free solution of each final population joins the run's archive (evaluation.final_population)
    final_validation: int = 0
    #: with final_validation: its T best teams also play the sequential protocol under noise on the training map,
    #: and the one that succeeds most often is archived (0: choose by the training protocol alone)
    final_sequential: int = 0
    #: with final_sequential: those teams also play F noisy sequential episodes on the run's own plus variants
    #: (runs with map_spread or map_branch), and the choice counts both (0: the training map alone)
    final_family: int = 0
    #: the engine of the final validation's sequential stage (evaluation.final_population.ENGINES)
    final_engine: str = "pymunk"
    #: GENERAL_FROM: "final_validation" transfers each run's final-validation pick (ranked across runs as
    #: general_rank says), so a pick chosen for the sequential protocol is the team that is tested
    general_from: str = "archive"
    #: GENERAL_RANKS: how the runs' teams are ranked for the top ones
    general_rank: str = "generalization"
    #: the noise preset of the transfer tests' noisy columns: "generalization" (the issue's test) or "robot" (a real
    #: Khepera III's sensors and a reflex that reads them: docs/results/emulator_check/)
    transfer_noise: str = "generalization"
    replays: int = 1  # most general solutions per mode filmed in each protocol and map (GIFs)
    reflex_arc: bool = False  # the arcing reflex (TaskParams.reflex_arc), beyond the paper
    reflex_arc_from: str = "start"  # or "robust_phase" (see EvolutionConfig.reflex_arc_from)
    input_ceiling: float = 1.0  # sensor values at or above it read 1 (TaskParams.input_ceiling), beyond the paper
    max_cycles: int = 1364  # shorter only for smoke tests
    signal_tick: int = 690
    neat: Mapping[str, Any] = field(default_factory=dict)  # NeatSettings overrides (e.g. from a config file)

    def __post_init__(self) -> None:
        object.__setattr__(self, "modes", tuple(self.modes))
        # the plan names the NEAT rules whose default changed, so an experiment.json says which ones its runs used
        object.__setattr__(self, "neat", {**{k: getattr(NeatSettings(), k) for k in V1_CHANGED_NEAT_DEFAULTS},
                                               **self.neat})
        bad = [m for m in self.modes if m not in MODES]
        if bad or not self.modes or len(set(self.modes)) != len(self.modes):
            raise ValueError(f"modes must be distinct values of {MODES}, got {list(self.modes)}")
        if self.init not in INITS:
            raise ValueError(f"init must be one of {INITS}, got {self.init!r}")
        for name in ("runs", "generations", "population", "top", "general_episodes", "transfer_episodes",
                     "max_cycles", "signal_tick"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, int) or v < 1:
                raise ValueError(f"{name} must be a positive integer, got {v!r}")
        for name in ("seed", "after_solved", "replays", "final_validation", "final_sequential", "final_family"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, int) or v < 0:
                raise ValueError(f"{name} must be a non-negative integer, got {v!r}")
        if self.final_engine not in ENGINES:
            raise ValueError(f"final_engine must be one of {ENGINES}, got {self.final_engine!r}")
        if self.general_from not in GENERAL_FROM:
            raise ValueError(f"general_from must be one of {GENERAL_FROM}, got {self.general_from!r}")
        if self.general_from == "final_validation" and not self.final_validation:
            raise ValueError("general_from 'final_validation' transfers the final validation's picks: give "
                             "final_validation (--final-validation N) too")
        if self.transfer_noise not in TRANSFER_NOISES:
            raise ValueError(f"transfer_noise must be one of {TRANSFER_NOISES}, got {self.transfer_noise!r}")
        if self.general_rank not in GENERAL_RANKS:
            raise ValueError(f"general_rank must be one of {GENERAL_RANKS}, got {self.general_rank!r}")
        if self.general_rank == "protocol" and not (self.general_from == "final_validation" and self.final_sequential):
            raise ValueError("general_rank 'protocol' ranks by the final validation's sequential successes: give "
                             "general_from 'final_validation' and final_sequential (--general-from final_validation "
                             "--final-sequential T) too")
        if self.final_family and not self.final_sequential:
            raise ValueError("final_family plays the sequential stage's teams on the runs' plus variants: give "
                             "final_sequential (--final-sequential T) too")
        if self.final_sequential and not self.final_validation:
            raise ValueError("final_sequential chooses among the final validation's best teams: give final_validation "
                             "(--final-validation N) too")
        check_seed(self.seed + self.runs - 1, "seed of the last run (seed + runs - 1)")
        self.train_config(self.modes[0], self.seed)  # validates the rest (population, NEAT overrides)

    # ------------------------------------------------------------------ runs
    def seeds(self) -> list[int]:
        return [self.seed + i for i in range(self.runs)]

    def run_name(self, mode: str, seed: int) -> str:
        return f"{mode}_s{seed:03d}"

    def train_config(self, mode: str, seed: int) -> EvolutionConfig:
        # with_noise follows, so a noise-dependent check (robust_from) sees the task's noise: build without it first
        shared = {k: getattr(self, k) for k in EVOLUTION_FIELDS}
        base = EvolutionConfig(mode=mode, generations=self.generations, seed=seed, stop_when_solved=True,
                               **{**shared, "robust_from": "start", "robust_delay": 0,
                                  "noise_free_branch": 0.0, "fitness_memory": "generation"}).with_noise(self.noise)
        base = replace(base, robust_from=self.robust_from, robust_delay=self.robust_delay,
                       noise_free_branch=self.noise_free_branch, fitness_memory=self.fitness_memory)
        base = base.with_overrides(pop=self.population)
        if self.neat:
            base = EvolutionConfig.from_mapping({**base.to_dict(), "neat": {**base.neat.to_dict(), **self.neat,
                                                                         "population_size": self.population}})
        task = base.task.to_dict()
        task.update(max_cycles=self.max_cycles, signal_tick=self.signal_tick, reflex_arc=self.reflex_arc,
                    input_ceiling=self.input_ceiling)
        return EvolutionConfig.from_mapping({**base.to_dict(), "task": task, "reflex_arc_from": self.reflex_arc_from})

    def tasks(self, out: str | Path) -> list[tuple[str, int, Path]]:
        """(mode, seed, run folder) for every run, seeds interleaved across modes so partial results stay paired."""
        root = Path(out) / "runs"
        return [(m, s, root / self.run_name(m, s)) for s in self.seeds() for m in self.modes]

    # ------------------------------------------------------------------ files
    def to_dict(self) -> dict[str, Any]:
        d = {f.name: getattr(self, f.name) for f in fields(self)}
        d["modes"] = list(self.modes)
        d["neat"] = dict(self.neat)
        return d

    @classmethod
    def from_mapping(cls, data: Mapping[str, Any]) -> ExperimentPlan:
        names = {f.name for f in fields(cls)}
        unknown = set(data) - names - {"kind", "version"}
        if unknown:
            raise ValueError(f"unknown experiment key(s) {sorted(unknown)}; known: {sorted(names)}")
        return cls(**{k: v for k, v in data.items() if k in names})

    @classmethod
    def load(cls, out: str | Path) -> ExperimentPlan:
        return cls.from_mapping(read_versioned_json(Path(out) / PLAN_FILE, "experiment"))

    def hardens(self, saved: ExperimentPlan) -> bool:
        """Whether this plan continues the runs of `saved` with a robust phase none of them has reached: every
        run is then resumed from its checkpoint into the robust phase, bit for bit the run this plan would make
        from the start (EvolutionConfig's `continues_before_robust_phase`).  The saved runs stopped at most
        `saved.after_solved` generations after their first solution, so this plan's robust phase must start after
        that (robust_delay >= saved.after_solved)."""
        return self.robust_from == "first_solution" and saved.after_solved <= self.robust_delay and all(
            continues_before_robust_phase(saved.train_config(m, self.seed), self.train_config(m, self.seed))
            for m in self.modes)

    def save_or_check(self, out: str | Path) -> None:
        """Write experiment.json, or refuse if the folder holds an experiment with another plan."""
        path = Path(out) / PLAN_FILE
        if path.exists():
            saved = ExperimentPlan.load(out)
            a, b = saved.to_dict(), self.to_dict()
            # a run is a pure function of its mode, seed and settings, so more runs, another mode beside the saved
            # ones, or another analysis leave every finished run valid; more generations after the first solution
            # continue the runs (from their checkpoints, bit-identically), fewer would leave them longer than planned
            may_change = ("runs", "modes", "replays", *REPORT_OPTIONS)
            differing = sorted(k for k in a if a[k] != b[k] and k not in may_change
                               and not (k == "after_solved" and b[k] > a[k]))
            if differing and self.hardens(saved):
                differing = []
            if differing:
                hint = ""
                if "neat" in differing:
                    hint = (f" (its NEAT overrides are {dict(a['neat'])}; pass them in the `neat` table of a "
                            "--config file)")
                raise ValueError(f"{str(out)!r} holds an experiment with a different plan ({differing}); "
                                 f"use another --out or the saved settings{hint}")
        Path(out).mkdir(parents=True, exist_ok=True)
        atomic_write_json(path, versioned("experiment", self.to_dict()))
