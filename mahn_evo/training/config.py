"""A training run's configuration: one validated record, from defaults, a TOML/JSON file and CLI flags.

Written to the run folder as `config.json`, so every result says exactly how it was made, and `--resume`
checks the folder's configuration against the one asked for.
"""
from __future__ import annotations

import json
import sys
from collections.abc import Mapping
from dataclasses import dataclass, field, fields, replace
from pathlib import Path
from typing import Any

import numpy as np

from mahn_envs.core import TaskParams
from mahn_envs.jsonfile import read_text_file
from mahn_envs.maps.variants import check_branch

from ..evaluation.task_setup import NOISE_PRESETS
from ..hyperneat.evaluation_settings import EvaluationSettings
from ..neat.settings import NeatSettings
from .lifetime import FITNESS_MEMORY

if sys.version_info >= (3, 11):
    import tomllib
else:  # Python 3.10: the same parser from PyPI (a dependency there, see pyproject.toml)
    import tomli as tomllib

INITS = ("iros2011", "minimal")
#: When a noisy (robust) evaluation starts: "start" (every generation) or "first_solution" (noise-free, exactly as a
#: run without noise, until the first solution and `robust_delay` generations more; then the robust evaluation
#: hardens the solved population)
ROBUST_FROM = ("start", "first_solution")


#: settings that only decide when a run ends; they may change when a run is resumed (e.g. more generations)
STOPPING_RULES = ("generations", "stop_when_solved", "after_solved")
#: settings that only score the generations of a robust phase (robust_from "first_solution"): a run may gain or
#: change its robust phase when resumed before that phase has started (`continues_before_robust_phase`)
ROBUST_PHASE_FIELDS = ("task", "episodes", "noise_draws", "aggregate", "quantile", "noise_free_episode",
                       "map_spread", "map_branch", "branch_sides", "plain_episodes", "sequential_episodes",
                       "sequential_plain", "noise_free_variants", "robust_from", "robust_delay",
                       "reflex_arc_from", "fitness_memory")
#: when a run with the arcing reflex (TaskParams.reflex_arc) uses it: "start" (every generation) or "robust_phase"
#: (the noise-free phase of robust_from "first_solution" keeps the original's reflex)
REFLEX_ARC_FROM = ("start", "robust_phase")


def robust_phase_start(robust_from: str, robust_delay: int, first_solved: int | None) -> int | None:
    """The first generation a run scores under noise (None: its first solution, which decides it, is not known);
    the one rule the trainer and the experiment table both read."""
    if robust_from == "start":
        return 0
    return None if first_solved is None else first_solved + robust_delay + 1


@dataclass(frozen=True)
class EvolutionConfig:
    """Everything that determines a run.  Same config (seed included) -> bit-identical run.

    The fields that say how genomes are scored (mode, map, task, episodes, seed, evaluate_modules, cppn_activation,
    decision, symmetry, noise_draws, aggregate, quantile, noise_free_episode, map_spread, map_branch,
    branch_sides, plain_episodes) are those of the evaluator's `EvaluationSettings`, which checks them;
    `evaluation` builds that record.  They stay flat here, as config.json has always held them.
    """

    mode: str = "situational"
    generations: int = 1000
    seed: int = 0
    #: the paper's seed genome (bias, y1, y2, S wired in; sign(z)*x1 and sign(z)*x2 modules for mirror-symmetric
    #: teams) with its Multiply modules evaluated, as the paper describes them.  At paper scale it reaches the
    #: "every POI patrolled" plateau (fitness > 50) by generation 29 where `minimal` needed ~540 (seed 1);
    #: see README "Training" for the numbers.
    init: str = "iros2011"
    map: str = "plus"
    evaluate_modules: bool = True
    #: "recursive": the original's one depth-first CPPN pass; "relax": its MultipleSteps relaxation (modules and
    #: recurrent CPPN links live; see mahn_evo/cppn/relax.py)
    cppn_activation: str = "recursive"
    #: "output": the original's winner-take-all on the output sigmoids; "net_input": on their net inputs, so no
    #: decision rests on a float32 saturation tie (see mahn_envs.core.controller.DECISIONS)
    decision: str = "output"
    #: "none" (the paper), "mirror" (bilateral symmetry by construction: the robots at -z get the mirror image of
    #: the brains painted at +z) or "best" (each team also scored in both mirror readings, the best counts; see
    #: mahn_evo.hyperneat.substrate.SYMMETRIES and EvaluationSettings.symmetry)
    symmetry: str = "none"
    #: episodes per team per generation; with noise in `task` (robust evaluation) see TeamEvaluator
    episodes: int = 1
    noise_draws: str = "fixed"
    aggregate: str = "mean"
    quantile: float = 0.25
    #: with noise: also score each team on one noise-free episode (see TeamEvaluator)
    noise_free_episode: bool = False
    #: 0 (the paper): every episode on `map`; S > 0 (map "plus"): the keyed episodes on plus variants with arm
    #: lengths scaled by [1 - S, 1 + S], drawn per episode key (see EvaluationSettings.map_spread)
    map_spread: float = 0.0
    #: 0 (the paper): side arms at the crossing; B > 0 cm (map "plus"): the keyed episodes' plus variants also have
    #: their side arms leaving the top arm at offsets drawn from [0, B] (see EvaluationSettings.map_branch)
    map_branch: float = 0.0
    #: with map_branch: "both", "one" or "one_short" (see EvaluationSettings.branch_sides)
    branch_sides: str = "both"
    #: with map_spread or map_branch: the first N keyed episodes of a generation on `map` itself, the others on
    #: variants (see EvaluationSettings.plain_episodes)
    plain_episodes: int = 0
    #: S > 0: each team also plays S episodes of the sequential (real-world) protocol per generation (of the robust
    #: phase, with robust_from "first_solution"), aggregated with the others (see EvaluationSettings)
    sequential_episodes: int = 0
    #: with map_spread or map_branch: the first P of them per generation on the map itself (see
    #: EvaluationSettings.sequential_plain)
    sequential_plain: int = 0
    #: N > 0 (with map_spread or map_branch): each team also plays N noise-free episodes per generation on plus
    #: variants, aggregated with the others (see EvaluationSettings.noise_free_variants)
    noise_free_variants: int = 0
    #: when the noisy evaluation starts (ROBUST_FROM); with "first_solution" the run is the noise-free run until its
    #: first solution, then the robust evaluation scores the generations after it (with stop_when_solved,
    #: `after_solved` of them): the solve rate of noise-free evolution, then selection for robustness
    robust_from: str = "start"
    #: with robust_from "first_solution": B > 0 cm scores every team of the noise-free phase on two noise-free
    #: episodes, one on `map` (plus) and one on a plus variant whose side arms leave the top arm at offsets drawn from
    #: [0, B] (a new variant each generation, the same for all its teams; with branch_sides "one" or "one_short"
    #: drawn that way, for both phases): exactly the evaluation of `--episodes 2 --map-branch B --branch-sides
    #: SIDES --plain-episodes 1 --noise-draws per_generation` without noise, so such a run can be hardened by
    #: resuming it.  A first solution then solves plus and an asymmetric crossing.  Why: hardening after a
    #: first solution on plus alone left the test map's branch where it was (docs/results/
    #: experiment_fresh_seeds_hardened/), so the turn rule has to meet a branch before the solution fixes it.
    noise_free_branch: float = 0.0
    #: with robust_from "first_solution": noise-free generations after the first solution before the robust phase.
    #: A first solution is one genome; within a few dozen noise-free generations it spreads to 50-100 (the faithful
    #: runs' logs), which gives the robust phase solved variants to select among.  Hardening at once (0) lost the
    #: solution (docs/results/experiment_harden/).
    robust_delay: int = 0
    #: with task.reflex_arc (the arcing reflex, beyond the paper): "start" drives every generation with it;
    #: "robust_phase" (with robust_from "first_solution") keeps the original's reflex until the robust phase, so the
    #: search is the faithful run's, bit for bit, and only the hardening meets the reflex the teams will drive with.
    #: Why: from the start the arcing reflex slowed the noise-free search on the seeds tried, while teams evolved
    #: with the original's reflex fail on robots mostly by its deadlock (docs/results/transfer_failures/).
    reflex_arc_from: str = "start"
    #: under noise with per-generation draws: "generation" (a team's fitness is this generation's score, as the
    #: paper) or "lifetime" (the mean of its scores over every generation the same genome was scored in, and the
    #: archive keeps the best team that solved every episode of at least LIFETIME_MIN_GENERATIONS of them).  Why: a
    #: few noisy episodes per generation tell a team failing 5 % of episodes from one failing 1 % by luck
    #: (mahn_evo.training.lifetime).  "archive": NEAT selects by the generation's score and only the archive keeps
    #: lifetime leaders.  With robust_from "first_solution" it applies to the robust phase.
    fitness_memory: str = "generation"
    #: weight of the behavioural-diversity bonus in NEAT's selection (mahn_evo.training.diversity): NEAT selects by
    #: fitness + diversity * (mean distance in cm of the team's robot end positions to its `diversity_k` nearest
    #: teams of the generation).  0 (the default, and the paper) selects by fitness alone.
    diversity: float = 0.0
    diversity_k: int = 15
    #: while no team has solved the task, replace the population by a fresh initial one every `restart_every`
    #: generations (0: never, as the paper).  Runs that solve, solve early or not for hundreds of generations (the
    #: plateau of docs/results/screen/), so several short attempts beat one long one; the generation count and the
    #: champion carry on across restarts.  Each restart's population is seeded from (seed, generation).
    restart_every: int = 0
    stop_when_solved: bool = False
    #: with stop_when_solved, generations still run after the first solution so the archive gathers the
    #: alternative solutions the generalisation test chooses among (0 = stop at once)
    after_solved: int = 0
    checkpoint_every: int = 1
    neat: NeatSettings = field(default_factory=NeatSettings)
    task: TaskParams = field(default_factory=TaskParams)

    def __post_init__(self) -> None:
        _ = self.evaluation  # building the evaluation settings checks their fields (EvaluationSettings)
        if self.init not in INITS:
            raise ValueError(f"init must be one of {INITS}, got {self.init!r}")
        if self.neat.cppn.evaluate_modules:  # a NEAT-level leftover: the trainer reads the top-level flag only
            raise ValueError("set evaluate_modules at the top level of the configuration, not under `neat`")
        for name in ("generations", "checkpoint_every"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, int) or v < 1:
                raise ValueError(f"{name} must be a positive integer, got {v!r}")
        if isinstance(self.after_solved, bool) or not isinstance(self.after_solved, int) or self.after_solved < 0:
            raise ValueError(f"after_solved must be a non-negative integer, got {self.after_solved!r}")
        if isinstance(self.diversity, bool) or not isinstance(self.diversity, (int, float)) \
                or not 0.0 <= self.diversity < float("inf"):
            raise ValueError(f"diversity must be a non-negative number, got {self.diversity!r}")
        if isinstance(self.restart_every, bool) or not isinstance(self.restart_every, int) or self.restart_every < 0:
            raise ValueError(f"restart_every must be a non-negative integer, got {self.restart_every!r}")
        if isinstance(self.diversity_k, bool) or not isinstance(self.diversity_k, int) or self.diversity_k < 1:
            raise ValueError(f"diversity_k must be a positive integer, got {self.diversity_k!r}")
        if self.robust_from not in ROBUST_FROM:
            raise ValueError(f"robust_from must be one of {ROBUST_FROM}, got {self.robust_from!r}")
        if isinstance(self.robust_delay, bool) or not isinstance(self.robust_delay, int) or self.robust_delay < 0:
            raise ValueError(f"robust_delay must be a non-negative integer, got {self.robust_delay!r}")
        if self.robust_delay and self.robust_from != "first_solution":
            raise ValueError("robust_delay counts generations after the first solution: it needs robust_from "
                             "'first_solution'")
        if self.robust_from == "first_solution" and self.stop_when_solved and self.after_solved <= self.robust_delay:
            raise ValueError(f"the run stops {self.after_solved} generation(s) after its first solution, before its "
                             f"robust phase (robust_delay {self.robust_delay}): give after_solved more than "
                             f"{self.robust_delay} (docs/results/experiment_harden/ used 250 with delay 50)")
        if self.noise_free_branch != 0.0:
            try:
                check_branch(self.noise_free_branch, 0.0, self.branch_sides)
            except ValueError as e:
                raise ValueError(f"noise_free_branch is the map_branch of the noise-free phase: {e}") from None
            if self.robust_from != "first_solution":
                raise ValueError("noise_free_branch scores the noise-free phase before a first solution on a branch "
                                 "variant too: it needs robust_from 'first_solution' (a run without that phase "
                                 "gets the same evaluation from episodes 2, map_branch B, plain_episodes 1 and "
                                 "noise_draws 'per_generation')")
            try:
                _ = self.noise_free_evaluation  # checks the rest (EvaluationSettings: the map must be plus)
            except ValueError as e:
                raise ValueError(f"noise_free_branch: {e}") from None
        if self.reflex_arc_from not in REFLEX_ARC_FROM:
            raise ValueError(f"reflex_arc_from must be one of {REFLEX_ARC_FROM}, got {self.reflex_arc_from!r}")
        if self.reflex_arc_from == "robust_phase" and not (self.task.reflex_arc
                                                            and self.robust_from == "first_solution"):
            raise ValueError("reflex_arc_from 'robust_phase' switches to the arcing reflex at the robust phase: it "
                             "needs the arcing reflex (task reflex_arc, --reflex-arc) and robust_from "
                             "'first_solution'")
        if self.fitness_memory not in FITNESS_MEMORY:
            raise ValueError(f"fitness_memory must be one of {FITNESS_MEMORY}, got {self.fitness_memory!r}")
        if self.fitness_memory != "generation" and (self.noise_draws != "per_generation"
                                                    or self.task == self.task.without_noise()):
            raise ValueError(f"fitness_memory {self.fitness_memory!r} averages a team's scores over generations "
                             "of fresh noisy episodes: it needs a noisy task (--noise) and noise_draws "
                             "'per_generation' (with fixed draws or no noise every generation repeats the same score)")
        if self.robust_from != "start" and self.task == self.task.without_noise():
            raise ValueError(f"robust_from {self.robust_from!r} switches to a noisy evaluation, but the task has no "
                             "noise: choose a noise preset (--noise generalization)")

    @property
    def evaluation(self) -> EvaluationSettings:
        """How this run scores its genomes: the fields of this configuration that `EvaluationSettings` names."""
        return EvaluationSettings(**{f.name: getattr(self, f.name) for f in fields(EvaluationSettings)})

    def robust_phase_start(self, first_solved: int | None) -> int | None:
        """The first generation scored by the robust evaluation, given the run's first solved generation (None:
        not yet known)."""
        return robust_phase_start(self.robust_from, self.robust_delay, first_solved)

    def restart_due(self, generation: int, first_solved: int | None) -> bool:
        """Whether `generation` starts from a fresh population (restart_every): a multiple of it, no solution yet."""
        return (self.restart_every > 0 and first_solved is None and generation > 0
                and generation % self.restart_every == 0)

    def restart_seed(self, generation: int) -> int:
        """The seed of the fresh population that starts `generation`: drawn from (seed, generation), so a run's
        every random choice still follows from its one seed and a resumed run restarts identically."""
        return int(np.random.SeedSequence(self.seed, spawn_key=(generation,)).generate_state(1, np.uint64)[0])

    @property
    def noise_free_evaluation(self) -> EvaluationSettings:
        """The evaluation before the first solution when robust_from is "first_solution": one noise-free episode,
        field for field that of the same run without noise (so that phase is bit-identical to it); with
        noise_free_branch B, two: on the map and on a branch variant drawn as `branch_sides` says, as the
        noise-free run with episodes 2, map_branch B, the same branch_sides, plain_episodes 1 and per-generation
        draws."""
        task = self.task.without_noise()
        if self.reflex_arc_from == "robust_phase":
            task = replace(task, reflex_arc=False)
        clean = replace(self.evaluation, task=task, episodes=1, noise_draws="fixed",
                        aggregate="mean", quantile=0.25, noise_free_episode=False, map_spread=0.0,
                        map_branch=0.0, branch_sides="both", plain_episodes=0, sequential_episodes=0,
                        sequential_plain=0, noise_free_variants=0)
        if self.noise_free_branch == 0.0:
            return clean
        return replace(clean, episodes=2, noise_draws="per_generation", map_branch=self.noise_free_branch,
                       branch_sides=self.branch_sides, plain_episodes=1)

    @property
    def n_cppn_inputs(self) -> int:
        return 6 if self.mode == "situational" else 5

    def to_dict(self) -> dict[str, Any]:
        d = {f.name: getattr(self, f.name) for f in fields(self) if f.name not in ("neat", "task")}
        d["neat"] = self.neat.to_dict()
        d["task"] = self.task.to_dict()
        return d

    @classmethod
    def from_mapping(cls, data: Mapping[str, Any]) -> EvolutionConfig:
        names = {f.name for f in fields(cls)}
        unknown = set(data) - names
        if unknown:
            raise ValueError(f"unknown configuration key(s) {sorted(unknown)}; known: {sorted(names)}")
        kw = dict(data)
        if "neat" in kw:
            kw["neat"] = NeatSettings.from_mapping(kw["neat"])
        if "task" in kw:
            kw["task"] = TaskParams.from_mapping(kw["task"])
        return cls(**kw)

    @classmethod
    def from_saved(cls, data: Mapping[str, Any]) -> EvolutionConfig:
        """A configuration a run saved (config.json, a checkpoint's), as read by mahn_evo.storage.files, which
        upgraded it to the current format (mahn_evo.storage.migrate) so it holds the values the run was made with."""
        return cls.from_mapping({k: v for k, v in data.items() if k not in ("kind", "version")})

    @property
    def noise_preset(self) -> str | None:
        """The name of the NOISE_PRESETS entry whose levels the task has ("none" without noise), None for other
        levels (an experiment plan names its noise)."""
        for name, levels in NOISE_PRESETS.items():
            if self.task == TaskParams.from_mapping({**self.task.without_noise().to_dict(), **levels}):
                return name
        return None

    def with_noise(self, preset: str) -> EvolutionConfig:
        """This configuration with the task noise of a named preset (mahn_evo.evaluation.task_setup.NOISE_PRESETS)."""
        if preset not in NOISE_PRESETS:
            raise ValueError(f"unknown noise preset {preset!r}; known: {sorted(NOISE_PRESETS)}")
        task = {**self.task.without_noise().to_dict(), **NOISE_PRESETS[preset]}
        return replace(self, task=TaskParams.from_mapping(task))

    def with_overrides(self, **changes: Any) -> EvolutionConfig:
        """Apply CLI-style overrides; `pop` is a shortcut for neat.population_size."""
        changes = {k: v for k, v in changes.items() if v is not None}
        neat = self.neat
        if "pop" in changes:
            pop = changes.pop("pop")
            # the species count range follows the population size again (a range set for another size is stale)
            neat = neat.replace(population_size=pop, species_count_min=None, species_count_max=None)
        return replace(self, neat=neat, **changes)


def continues_before_robust_phase(saved: EvolutionConfig, asked: EvolutionConfig) -> bool:
    """Whether `asked` scores every generation before its robust phase exactly as `saved` scored the generations
    before its own (all of them, when `saved` has none): `asked` has robust_from "first_solution" and the two differ
    only in the robust phase's settings (ROBUST_PHASE_FIELDS, the noise-free episode aside) and the stopping rules.

    Why: a solved run (e.g. of the noise-free `best-restarts` preset) can then be hardened under noise by resuming
    it with a robust phase, bit for bit the run a fresh start with that phase would have made, provided it has not
    yet run a generation the robust phase would have scored (see `Trainer`)."""
    if asked.robust_from != "first_solution":
        return False
    before = saved.noise_free_evaluation if saved.robust_from == "first_solution" else saved.evaluation
    if before != asked.noise_free_evaluation:
        return False
    a, b = saved.to_dict(), asked.to_dict()
    # noise_free_branch only shapes the evaluation before the robust phase, whose equality is checked above
    return all(a[k] == b[k] for k in a if k not in ROBUST_PHASE_FIELDS + STOPPING_RULES + ("noise_free_branch",))


def load_config_file(path: str | Path, base: EvolutionConfig | None = None) -> EvolutionConfig:
    """A EvolutionConfig from a TOML/JSON file; the file's fields (and its `neat`/`task` keys) override `base`."""
    p = Path(path)
    text = read_text_file(p, "config")
    try:
        data = tomllib.loads(text) if p.suffix == ".toml" else json.loads(text)
    except (tomllib.TOMLDecodeError, json.JSONDecodeError, RecursionError) as exc:
        raise ValueError(f"config file {str(p)!r} is not valid {p.suffix[1:].upper() or 'JSON'}: {exc!r}") from exc
    if not isinstance(data, dict):
        raise ValueError(f"config file {str(p)!r} must hold a table (JSON object) of EvolutionConfig fields")
    if base is None:
        return EvolutionConfig.from_mapping(data)
    merged = {**base.to_dict(), **data}
    for table in ("neat", "task"):
        if table in data:
            if not isinstance(data[table], dict):
                raise ValueError(f"config file {str(p)!r}: `{table}` must be a table")
            merged[table] = {**base.to_dict()[table], **data[table]}
    return EvolutionConfig.from_mapping(merged)
