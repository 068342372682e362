"""Polishing a solved team for robots: CMA-ES on its CPPN's connection weights under noisy episodes (a negative
result: README.md).

Why: the teams evolution finds mostly fail the noisy real-world (sequential) protocol on the test map, and the
population-wide hardening phases help some runs and not others (docs/results/). A solved team's behaviour is set
by its CPPN's topology; what noise breaks is often a margin (a decision that a small perturbation of the inputs
flips). A local search over the CPPN's weights alone, scored on many noisy episodes with common random numbers,
can widen those margins without giving up the behaviour, at the cost of a few thousand episodes (minutes on one
core), and keeps the indirect encoding: the polished team is still painted by one CPPN.

The search (`cma`, a well-kept CMA-ES): x0 = the CPPN's weights, bounded by NEAT's weight limit, each generation
scoring every candidate on the same fresh noisy episodes (TeamEvaluator with the hardened-sequential episode mix:
training episodes on `plus` and one-sided branch variants, one noise-free, sequential-protocol episodes on `plus`
and variants; never the test map). The original team, each generation's best candidate and the final mean are then
validated on episodes of their own and the best by validation is kept, so a polished team is never worse than the
original on those episodes. Same seed, same result.
"""
from __future__ import annotations

import sys
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from mahn_envs.core import BatchSim
from mahn_envs.core.sequential import SequentialSettings, sequential_task
from mahn_envs.policies.team_controllers import TeamControllers
from mahn_evo.cppn import compile_genome
from mahn_evo.evaluation.task_setup import task_params
from mahn_evo.experiment.plan import ExperimentPlan
from mahn_evo.experiment.transfer import TRANSFER_MAPS, transfer_tests
from mahn_evo.hyperneat.evaluation_settings import EvaluationSettings
from mahn_evo.hyperneat.substrate import decode_population, team_reading
from mahn_evo.hyperneat.team_evaluator import TeamEvaluator
from mahn_evo.neat.genome import Genome
from mahn_evo.neat.settings import MutationSettings
from mahn_evo.storage.files import atomic_write_csv, atomic_write_json, versioned
from mahn_evo.training.champion import Champion, champion_decoding

KIND = "polish"
#: validation episodes use generations from here on, so they never share a key with the search's
VALIDATION_FROM = 1_000_000
LOG_HEADER = ["generation", "best", "median", "mean", "sigma", "seconds"]


@dataclass(frozen=True)
class PolishSettings:
    """The search and the episodes that score it (defaults: the hardened-sequential mix, more episodes)."""

    generations: int = 60
    popsize: int = 16
    #: CMA-ES's initial step size, in CPPN weight units (NEAT's weights lie in [-1.5, 1.5]; a solved team's
    #: behaviour survives changes of about 1e-4 and breaks at 1e-3: README.md)
    sigma: float = 3e-4
    seed: int = 1
    #: the task noise the episodes are played under (a NOISE_PRESETS name)
    noise: str = "generalization"
    #: noisy training-protocol episodes per candidate and generation (the first `plain_episodes` on plus)
    episodes: int = 4
    plain_episodes: int = 1
    #: noisy sequential-protocol episodes per candidate and generation (the first `sequential_plain` on plus)
    sequential_episodes: int = 6
    sequential_plain: int = 3
    #: the one-sided branch variants' largest offset (cm), as the hardened-sequential preset
    map_branch: float = 49.0
    #: generations of episodes each finalist is validated on
    validation: int = 8

    def __post_init__(self) -> None:
        for name in ("generations", "popsize", "episodes", "sequential_episodes", "validation"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int) or value < 1:
                raise ValueError(f"{name} must be a positive integer, got {value!r}")
        if self.popsize < 2:
            raise ValueError(f"popsize must be at least 2 (CMA-ES ranks its candidates), got {self.popsize}")
        if not isinstance(self.sigma, (int, float)) or isinstance(self.sigma, bool) or not self.sigma > 0:
            raise ValueError(f"sigma must be a positive number, got {self.sigma!r}")
        task_params(self.noise)  # an unknown noise preset is an error naming the presets

    def evaluation(self, champ: Champion, activation: str, modules: bool) -> EvaluationSettings:
        """The episodes a candidate is scored on: noisy, fresh each generation, common to every candidate."""
        return EvaluationSettings(
            mode=champ.mode, map="plus", task=champ.task(task_params(self.noise)), episodes=self.episodes,
            seed=self.seed, evaluate_modules=modules, cppn_activation=activation, noise_draws="per_generation",
            noise_free_episode=True, map_branch=self.map_branch, branch_sides="one_short",
            plain_episodes=self.plain_episodes, sequential_episodes=self.sequential_episodes,
            sequential_plain=self.sequential_plain)


@dataclass
class PolishResult:
    champion: Champion
    #: validation fitness (mean over the validation generations) of the original team and of the kept one
    original: float
    polished: float
    #: which finalist was kept: "original", "mean" or "best of generation G"
    chosen: str
    finalists: list[dict[str, Any]] = field(default_factory=list)
    log: list[list[Any]] = field(default_factory=list)
    seconds: float = 0.0


class _Decoder:
    """CPPN weights -> the champion's team (its decoding and mirror reading), for a batch of weight vectors."""

    def __init__(self, champ: Champion) -> None:
        self.champ = champ
        self.activation, self.modules, self.reading = champion_decoding(champ)

    def genome(self, weights: np.ndarray) -> Genome:
        return self.champ.genome.with_weights(np.asarray(weights, dtype=np.float64))

    def teams(self, weights: list[np.ndarray]) -> TeamControllers:
        plans = [compile_genome(self.genome(w), self.activation, self.modules) for w in weights]
        painted = decode_population(plans, self.champ.mode, self.champ.controllers.n_robots)
        return team_reading(painted, self.reading).with_decision(self.champ.controllers.decision)


def _validate(evaluator: TeamEvaluator, teams: TeamControllers, generations: int) -> np.ndarray:
    """Each team's fitness averaged over `generations` generations of validation episodes."""
    total = np.zeros(teams.w_ih.shape[0])
    for g in range(generations):
        fitness, _ = evaluator.score(teams, VALIDATION_FROM + g)
        total += fitness
    return total / generations


def polish(champ: Champion, settings: PolishSettings = PolishSettings(),
           log: Callable[[str], None] | None = None) -> PolishResult:
    """Search the champion's CPPN weights for a team that scores better on noisy episodes (see the module)."""
    import cma

    t0 = time.perf_counter()
    decoder = _Decoder(champ)
    evaluator = TeamEvaluator(settings.evaluation(champ, decoder.activation, decoder.modules))
    x0 = np.asarray(champ.genome.weight, dtype=np.float64)
    limit = MutationSettings().weight_limit
    es = cma.CMAEvolutionStrategy(x0, settings.sigma, {
        "popsize": settings.popsize, "seed": settings.seed + 1,  # cma draws a random seed for 0
        "bounds": [-limit, limit], "verbose": -9, "verb_log": 0, "verb_disp": 0, "tolfun": 0, "tolx": 0,
        "tolfunhist": 0, "tolstagnation": 10**9, "maxiter": settings.generations})
    finalists: list[tuple[str, np.ndarray]] = [("original", x0)]
    rows: list[list[Any]] = []
    for g in range(settings.generations):
        xs = [np.asarray(x) for x in es.ask()]
        fitness, _ = evaluator.score(decoder.teams(xs), g)
        es.tell(xs, list(-fitness))  # cma minimises
        best = int(np.argmax(fitness))
        finalists.append((f"best of generation {g}", xs[best]))
        rows.append([g, float(fitness[best]), float(np.median(fitness)), float(fitness.mean()), float(es.sigma),
                     round(time.perf_counter() - t0, 2)])
        if log is not None:
            log(f"generation {g}: best {fitness[best]:.2f}, median {np.median(fitness):.2f}, sigma {es.sigma:.4f}")
    finalists.append(("mean", np.asarray(es.mean)))
    validated = _validate(evaluator, decoder.teams([x for _, x in finalists]), settings.validation)
    keep = int(np.argmax(validated))  # the first of equals: the original when nothing beats it
    name, weights = finalists[keep]
    genome = decoder.genome(weights)
    team = decoder.teams([weights]).team(0)
    clean = BatchSim(champ.map, 1, champ.task()).run_controllers(team, seed=settings.seed)
    polished = replace(champ, genome=genome, controllers=team, fitness=float(clean.fitness[0]),
                       solved=bool(clean.solved[0]))
    return PolishResult(
        champion=polished, original=float(validated[0]), polished=float(validated[keep]), chosen=name,
        finalists=[{"name": n, "validation": float(v)} for (n, _), v in zip(finalists, validated)], log=rows,
        seconds=time.perf_counter() - t0)


def sequential_successes(champ: Champion, episodes: int = 200, noise: str = "generalization") -> dict[str, float]:
    """The fraction of `episodes` noisy sequential-protocol episodes (the compiled core; its successes predict the
    pymunk transfer test, r = 0.95: docs/results/selection/) the team succeeds in, on plus and on the test map,
    which the search never plays."""
    out = {}
    for m in ("plus", "asymmetric_plus"):
        sim = BatchSim(m, episodes, sequential_task(champ.task(task_params(noise)), SequentialSettings()))
        seq = sim.run_sequential(champ.controllers, seed=7, episode_keys=np.arange(episodes))
        out[m] = float(np.mean(seq.success))
    return out


def issue_test(champ: Champion) -> dict[str, float]:
    """The issue's transfer test: 10 noisy sequential pymunk episodes per map, generalisation noise (the
    experiments' `transfer_tests`, with the plan of docs/results/experiment_hardened_sequential/)."""
    plan = ExperimentPlan.load(Path(__file__).resolve().parents[1] / "experiment_hardened_sequential")
    tests = transfer_tests(champ, plan)
    return {m: tests[m]["sequential_noisy"]["success_fraction"] for m in TRANSFER_MAPS}


def polish_to_folder(champion_file: str | Path, out: str | Path, settings: PolishSettings = PolishSettings(),
                     log: Callable[[str], None] | None = None) -> PolishResult:
    """Polish a champion file; write out/champion.json (the kept team, a champion file like any other: its fitness
    and solved flag are its noise-free training episode on its map), out/polish.csv (the search, per generation)
    and out/summary.json (settings, validation of the original and of the kept team, every finalist)."""
    champ = Champion.load(champion_file)
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    result = polish(champ, settings, log)
    result.champion.save(out / "champion.json")
    atomic_write_csv(out / "polish.csv", LOG_HEADER, result.log)
    atomic_write_json(out / "summary.json", versioned(KIND, {
        "champion": str(champion_file), "settings": asdict(settings), "original_validation": result.original,
        "polished_validation": result.polished, "chosen": result.chosen,
        "noise_free": {"fitness": result.champion.fitness, "solved": result.champion.solved},
        "finalists": result.finalists, "seconds": round(result.seconds, 1),
        "sequential_successes": {"original": sequential_successes(champ),
                                 "polished": sequential_successes(result.champion)},
        "issue_test": {"original": issue_test(champ), "polished": issue_test(result.champion)}}))
    return result


def main(argv: list[str]) -> int:
    """python docs/results/polish/polish.py CHAMPION OUT [GENERATIONS] [SIGMA]"""
    if len(argv) not in (2, 3, 4):
        print(main.__doc__, file=sys.stderr)
        return 2
    settings = PolishSettings(generations=int(argv[2]) if len(argv) > 2 else 60,
                              sigma=float(argv[3]) if len(argv) > 3 else PolishSettings.sigma)
    result = polish_to_folder(argv[0], argv[1], settings, log=print)
    print(f"validation: original {result.original:.2f}, kept ({result.chosen}) {result.polished:.2f}")
    print((Path(argv[1]) / "summary.json").read_text())
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
