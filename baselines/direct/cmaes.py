"""Direct-encoding evolution control: CMA-ES (the `cma` package) evolves the weights of the same recurrent
7-9-3 substrate networks that HyperNEAT's CPPNs decode, scored by the trainer's evaluator.

Why: HyperNEAT differs from RL both in *how* controllers are searched (evolution, not gradients) and in *how*
they are encoded (a CPPN painting the weights, not the weights themselves).  Evolving the weights directly,
through the same networks (`mahn_envs.policies.team_controllers.TeamControllers`), the same connections
(`mahn_evo.hyperneat.substrate.query_layout`: one evolved number per substrate connection or bias, the signal
input only in standard geometry) and the same evaluator (`mahn_evo.hyperneat.team_evaluator.TeamEvaluator.score`),
separates the two.

Genome -> controllers: every value is clipped to [-3, 3], the range of HyperNEAT's decoded weights and
biases; no normalisation (that is part of HyperNEAT's decoding, not of the networks).  Standard geometry has
3 robots x 183 parameters = 549, situational 3 x 2 brains x 174 = 1044.  The search starts at all-zero
weights (every robot drives forward) with step size `sigma0`.

Run folder (resumable, deterministic from the seed):
  config.json       the settings
  checkpoint.json   versioned: generation, the `cma` version, a digest of the search state, log, best
  history.npz       the fitness of every candidate so far, in order (`fitness`), and each generation's population
                    size (`popsizes`); files without `popsizes` (before restarts) hold a (generations x popsize) array
  log.csv           generation, evaluations, best_fitness, mean_fitness, best_ever, solved, n_solved, sigma,
                    seconds (the columns `baselines.comparison.compare.evo_curve` reads; budget = evaluations x
                    ticks x 3)
  best_controllers.json  the best team so far (TeamControllers JSON, with its fitness)
  summary.json      method `cmaes_direct_<mode>` (`ipop_cmaes_direct_<mode>` with restarts), seed, best fitness,
                    solved, evaluations, wall time (and, with restarts, where each search started)
Restarts (`restart_patience` P > 0, IPOP-CMA-ES, Auger and Hansen 2005): when the current search's best fitness has
not risen by RESTART_MIN_DELTA for P generations, a new search starts from the same point and step size with twice
the population, until the budget of `generations` x `popsize` candidates is spent.  Why: one CMA-ES converges
(its step size fell below 0.01 by generation 650 of situational seed 1 and its best stayed 61.2 for the other 4350
of 5000 generations), so without restarts most of HyperNEAT's budget is spent searching nowhere.  P = 0 is one
search for the whole budget (situational seeds 1-2 ran so).
Resume *replays* the search: CMA-ES is a deterministic function of its seed and the fitness values it was
told, so asking and telling the recorded values again rebuilds its exact state without a pickle and without
simulating anything (seconds to minutes for thousands of generations); the digest of mean, step size and
covariance is checked after the replay, and a mismatch (another `cma` version or BLAS) is an error.
"""
from __future__ import annotations

import hashlib
import math
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np

from mahn_envs.core.params import TaskParams
from mahn_envs.policies.team_controllers import TeamControllers
from mahn_evo.hyperneat.evaluation_settings import EvaluationSettings
from mahn_evo.hyperneat.substrate import MODES, WEIGHT_RANGE, query_layout
from mahn_evo.hyperneat.team_evaluator import TeamEvaluator
from mahn_evo.storage.files import atomic_write_csv, atomic_write_json, read_versioned_json, versioned

from ..io import new_run_folder, settings_from_dict

LOG_HEADER = ["generation", "evaluations", "best_fitness", "mean_fitness", "best_ever", "solved", "n_solved",
              "sigma", "cpu_seconds", "seconds"]
STOPPING_RULES = ("generations",)
#: with restarts: a search's best must rise by more than this (fitness units; a solved team scores > 100) to count
#: as progress, so a converged search creeping up by hundredths is restarted
RESTART_MIN_DELTA = 0.1


@dataclass
class CMAConfig:
    mode: str = "situational"  #: controller geometry: situational (2 brains per robot) or standard (1)
    generations: int = 100
    popsize: int = 100
    sigma0: float = 1.0
    seed: int = 0
    map: str = "plus"
    episodes: int = 1  #: episodes per candidate (the noise-free task: 1 is exact)
    max_cycles: int = 1364
    signal_tick: int = 690
    #: 0: one search for the whole budget; P > 0: IPOP restarts after P generations without progress (module doc)
    restart_patience: int = 0

    def __post_init__(self) -> None:
        if self.mode not in MODES:
            raise ValueError(f"mode must be one of {MODES}, got {self.mode!r}")
        if isinstance(self.restart_patience, bool) or not isinstance(self.restart_patience, int) \
                or self.restart_patience < 0:
            raise ValueError(f"restart_patience must be a non-negative integer, got {self.restart_patience!r}")
        for name in ("generations", "popsize", "episodes"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, int) or v < 1:
                raise ValueError(f"{name} must be a positive integer, got {v!r}")
        if self.popsize < 2:
            raise ValueError(f"popsize must be at least 2, got {self.popsize}")
        if isinstance(self.seed, bool) or not isinstance(self.seed, int) or self.seed < 0:
            raise ValueError(f"seed must be a non-negative integer, got {self.seed!r}")
        if not (math.isfinite(self.sigma0) and self.sigma0 > 0):
            raise ValueError(f"sigma0 must be a finite positive number, got {self.sigma0!r}")
        _ = self.task_params  # validates max_cycles / signal_tick

    @property
    def task_params(self) -> TaskParams:
        return TaskParams(max_cycles=self.max_cycles, signal_tick=self.signal_tick)

    @property
    def budget(self) -> int:
        """Candidates the run may evaluate: `generations` generations of the first search's population."""
        return self.generations * self.popsize

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> CMAConfig:
        return settings_from_dict(cls, d, "CMA-ES", derived=("method",))


class DirectEncoding:
    """Flat parameter vectors <-> batches of team controllers, on the substrate's connections."""

    def __init__(self, mode: str, n_robots: int = 3) -> None:
        layout = query_layout(mode, n_robots)
        self.mask_ih = layout.q_ih >= 0  # (R, K, 9, 7): the signal column exists only in standard geometry
        self.shapes = {"w_ih": layout.q_ih.shape, "w_hh": layout.q_hh.shape, "w_ho": layout.q_ho.shape,
                       "b_h": layout.q_bh.shape, "b_o": layout.q_bo.shape}
        n_ih = int(self.mask_ih.sum())
        self.sizes = {"w_ih": n_ih, **{k: int(np.prod(s)) for k, s in self.shapes.items() if k != "w_ih"}}
        self.n_params = sum(self.sizes.values())

    def decode(self, x: np.ndarray) -> TeamControllers:
        """(N, n_params) -> N teams; values clipped to +-3 (HyperNEAT's weight and bias range)."""
        x = np.clip(np.atleast_2d(np.asarray(x, dtype=np.float64)), -WEIGHT_RANGE, WEIGHT_RANGE)
        if x.shape[1] != self.n_params:
            raise ValueError(f"parameter vectors must have {self.n_params} values, got {x.shape[1]}")
        n = x.shape[0]
        arrays, at = {}, 0
        for name in ("w_ih", "w_hh", "w_ho", "b_h", "b_o"):
            chunk = x[:, at:at + self.sizes[name]]
            at += self.sizes[name]
            if name == "w_ih":
                a = np.zeros((n,) + self.shapes[name])
                a[:, self.mask_ih] = chunk
            else:
                a = chunk.reshape((n,) + self.shapes[name])
            arrays[name] = a.astype(np.float32)
        return TeamControllers(arrays["w_ih"], arrays["w_hh"], arrays["w_ho"], arrays["b_h"], arrays["b_o"])


def _digest(es: Any) -> str:
    h = hashlib.sha256()
    for a in (np.asarray(es.mean, dtype=np.float64), np.asarray([es.sigma], dtype=np.float64),
              np.asarray(es.sm.C, dtype=np.float64)):
        h.update(np.ascontiguousarray(a).tobytes())
    return h.hexdigest()


class GenerationLoop:
    """The run loop of a direct-encoding control, written once for CMA-ES and NEAT: generations until the budget,
    the log and the checkpoint written every `checkpoint_every` generations and at the end (`finish`)."""

    log_header: list[str]
    out: Path
    rows: list[list]
    cfg: Any

    @property
    def generation(self) -> int:  # pragma: no cover - each control implements it
        raise NotImplementedError

    def step(self) -> list:  # pragma: no cover - each control implements it
        raise NotImplementedError

    def _checkpoint(self) -> None:  # pragma: no cover - each control implements it
        raise NotImplementedError

    def finish(self) -> dict:  # pragma: no cover - each control implements it
        raise NotImplementedError

    def more(self) -> bool:
        """Whether the budget allows another generation."""
        return self.generation < self.cfg.generations

    def _save(self) -> None:
        atomic_write_csv(self.out / "log.csv", self.log_header, self.rows)
        self._checkpoint()

    def run(self, on_generation: Callable[[list], None] | None = None, checkpoint_every: int = 10) -> dict:
        if isinstance(checkpoint_every, bool) or not isinstance(checkpoint_every, int) or checkpoint_every < 1:
            raise ValueError(f"checkpoint_every must be a positive integer, got {checkpoint_every!r}")
        while self.more():
            row = self.step()
            if self.generation % checkpoint_every == 0:
                self._save()
            if on_generation is not None:
                on_generation(row)
        return self.finish()


class DirectCMA(GenerationLoop):
    """One CMA-ES run in a folder; `DirectCMA(cfg, out, resume=True)` continues the checkpoint there."""

    log_header = LOG_HEADER

    def __init__(self, cfg: CMAConfig, out: str | Path, resume: bool = False) -> None:
        import cma

        self.cma = cma
        self.cfg = cfg
        self.out = Path(out)
        self.evaluator = TeamEvaluator(EvaluationSettings(mode=cfg.mode, map=cfg.map, task=cfg.task_params,
                                                          episodes=cfg.episodes, seed=cfg.seed))
        self.encoding = DirectEncoding(cfg.mode, self.evaluator.world.n_robots)
        self.n_robots = self.evaluator.world.n_robots
        #: the generation each search started at (one entry without restarts)
        self.searches: list[int] = [0]
        self.es = self._new_es()
        self._search_best = -math.inf  # the current search's best, as counted for progress (RESTART_MIN_DELTA)
        self._search_progress = 0  # the generation it last rose
        self.history: list[np.ndarray] = []
        self.rows: list[list] = []
        self.best_fitness = -math.inf
        self.first_solved: int | None = None
        self.wall = 0.0
        self.cpu = 0.0  #: CPU-seconds of this process (all threads): the compute-matched budget axis
        ckpt = self.out / "checkpoint.json"
        if resume:
            self._resume(ckpt)
        else:
            new_run_folder(self.out, "cma_config", {**cfg.to_dict(), "method": self.method})

    @property
    def method(self) -> str:
        """`cmaes_direct_<mode>`, or `ipop_cmaes_direct_<mode>` with restarts: the comparison keeps the two apart."""
        return f"{'ipop_' if self.cfg.restart_patience else ''}cmaes_direct_{self.cfg.mode}"

    @property
    def generation(self) -> int:
        return len(self.history)

    @property
    def evaluations(self) -> int:
        """Candidates evaluated so far (times episodes: episodes)."""
        return sum(len(h) for h in self.history)

    @property
    def popsize(self) -> int:
        """The current search's population: the first one's, doubled at each restart."""
        return self.cfg.popsize * 2 ** (len(self.searches) - 1)

    def more(self) -> bool:
        return self.evaluations + self.popsize <= self.cfg.budget

    def _new_es(self) -> Any:
        """The current search's CMA-ES: the all-zero start, sigma0, its population, its own random stream (the
        first search's is the one runs without restarts always had)."""
        k = len(self.searches) - 1
        rng = np.random.default_rng([self.cfg.seed, 0xC3A] if k == 0 else [self.cfg.seed, 0xC3A, k])
        opts = {"popsize": self.popsize, "seed": np.nan, "verbose": -9,
                "randn": lambda *shape: rng.standard_normal(shape),
                # the run length is ours (a budget), not CMA-ES's convergence tests
                "maxiter": np.inf, "maxfevals": np.inf, "tolfun": 0, "tolfunhist": 0, "tolx": 0,
                "tolstagnation": np.inf, "tolflatfitness": np.inf, "tolconditioncov": np.inf}
        return self.cma.CMAEvolutionStrategy(np.zeros(self.encoding.n_params), self.cfg.sigma0, opts)

    # ------------------------------------------------------------------ files
    def _after_tell(self, fitness: np.ndarray) -> None:
        """Progress bookkeeping of the current search and, with restarts, the next search when it stalled: the
        same rule in a run and in its replay."""
        gen = self.generation - 1  # the generation just told
        top = float(np.max(fitness))
        if top > self._search_best + RESTART_MIN_DELTA:
            self._search_best, self._search_progress = top, gen
        if self.cfg.restart_patience and gen - self._search_progress >= self.cfg.restart_patience:
            self.searches.append(gen + 1)
            self.es = self._new_es()
            self._search_best, self._search_progress = -math.inf, gen + 1

    def _checkpoint(self) -> None:
        flat = np.concatenate(self.history) if self.history else np.zeros(0)
        tmp = self.out / ".history.tmp.npz"
        np.savez(tmp, fitness=flat, popsizes=np.array([len(h) for h in self.history], dtype=np.int64))
        tmp.replace(self.out / "history.npz")
        state = {"config": self.cfg.to_dict(), "generation": self.generation, "cma_version": self.cma.__version__,
                 "digest": _digest(self.es), "best_fitness": None if not math.isfinite(self.best_fitness)
                 else self.best_fitness, "first_solved": self.first_solved, "wall_seconds": self.wall,
                 "cpu_seconds": self.cpu, "log": self.rows,
                 # the budget (candidates) this run had spent when saved, None while it could go on
                 "budget_spent": None if self.more() else self.cfg.budget}
        atomic_write_json(self.out / "checkpoint.json", versioned("cma_checkpoint", state))

    def _resume(self, ckpt: Path) -> None:
        data = read_versioned_json(ckpt, "cma_checkpoint")
        saved, asked = CMAConfig.from_dict(data["config"]).to_dict(), self.cfg.to_dict()
        differing = sorted(k for k in asked if k not in STOPPING_RULES and saved[k] != asked[k])
        if differing:
            raise ValueError(f"cannot resume {str(self.out)!r}: settings differ in {differing} (the run was made "
                             f"with {', '.join(f'{k} = {saved[k]!r}' for k in differing)})")
        if data["cma_version"] != self.cma.__version__:
            raise ValueError(f"{str(ckpt)!r} was written with cma {data['cma_version']}, this is cma "
                             f"{self.cma.__version__}: the replay would not rebuild the same search state")
        path = self.out / "history.npz"
        n = int(data["generation"])
        hist = _read_history(path, n, self.cfg.popsize)
        self.history = []
        for g in range(n):  # replay: ask, tell the recorded fitness (minimised: negated), restart as the run did
            if len(hist[g]) != self.popsize:
                raise ValueError(f"history file {str(path)!r} holds {len(hist[g])} fitness values for generation "
                                 f"{g}, whose search asks {self.popsize}: it is not this run's history")
            self._last_asked = self.es.ask()
            self._tell(hist[g])
            self.history.append(hist[g])
            self._after_tell(hist[g])
        if _digest(self.es) != data["digest"]:
            raise ValueError(f"replaying {str(path)!r} did not rebuild the saved CMA-ES state (another numpy / "
                             "BLAS build?); the run cannot be continued bit-identically here")
        try:
            self.best_fitness = -math.inf if data["best_fitness"] is None else float(data["best_fitness"])
            self.first_solved = data["first_solved"]
            self.wall = float(data["wall_seconds"])
            self.cpu = float(data["cpu_seconds"])
            self.rows = data["log"]
        except (KeyError, TypeError, ValueError) as exc:
            raise ValueError(f"checkpoint file {str(ckpt)!r} is damaged or from another format (missing or bad "
                             f"field: {exc})") from exc
        if saved["generations"] != asked["generations"]:
            atomic_write_json(self.out / "config.json", versioned("cma_config", {**asked, "method": self.method}))

    def _tell(self, fitness: np.ndarray) -> None:
        solutions = self._last_asked
        self.es.tell(solutions, list(-np.asarray(fitness, dtype=np.float64)))

    # ------------------------------------------------------------------ loop
    def step(self) -> list:
        t0, c0 = time.perf_counter(), time.process_time()
        gen = self.generation
        xs = self.es.ask()
        self._last_asked = xs
        controllers = self.encoding.decode(np.asarray(xs))
        fitness, solved = self.evaluator.score(controllers)
        self._tell(fitness)
        sigma = float(self.es.sigma)  # the step size of the search that made this generation
        self.history.append(np.asarray(fitness, dtype=np.float64))
        self._after_tell(self.history[-1])
        best = int(np.argmax(fitness))
        solved_mask = solved >= 1.0
        if fitness[best] > self.best_fitness:
            self.best_fitness = float(fitness[best])
            atomic_write_json(self.out / "best_controllers.json", versioned("cma_best", {
                "method": self.method, "generation": gen, "fitness": self.best_fitness,
                "solved": bool(solved_mask[best]), "controllers": controllers.team(best).to_dict()}))
        if solved_mask.any() and self.first_solved is None:
            self.first_solved = gen
        seconds = time.perf_counter() - t0
        self.wall += seconds
        self.cpu += time.process_time() - c0
        row = [gen, self.evaluations * self.cfg.episodes, float(fitness[best]), float(fitness.mean()),
               float(self.best_fitness), bool(solved_mask[best]), int(solved_mask.sum()), sigma,
               round(self.cpu, 3), round(seconds, 4)]
        self.rows.append(row)
        return row

    def finish(self) -> dict:
        self._save()
        summary = {"method": self.method, "mode": self.cfg.mode, "seed": self.cfg.seed, "map": self.cfg.map,
                   "generations": self.generation, "population": self.cfg.popsize,
                   "n_params": self.encoding.n_params,
                   "best_fitness": None if not math.isfinite(self.best_fitness) else self.best_fitness,
                   "solved": self.first_solved is not None, "first_solved_generation": self.first_solved,
                   "evaluations": self.rows[-1][1] if self.rows else 0,
                   "robot_steps": (self.rows[-1][1] if self.rows else 0) * self.cfg.max_cycles * self.n_robots,
                   "wall_seconds": round(self.wall, 3), "cpu_seconds": round(self.cpu, 3)}
        if self.cfg.restart_patience:
            summary["searches"] = [{"generation": g, "popsize": self.cfg.popsize * 2 ** k}
                                   for k, g in enumerate(self.searches)]
        atomic_write_json(self.out / "summary.json", summary)
        return summary


def _read_history(path: Path, n: int, popsize: int) -> list[np.ndarray]:
    """The first n generations' fitness values of a history file (either format, see the module doc)."""
    try:
        with np.load(path, allow_pickle=False) as f:
            fitness = np.asarray(f["fitness"], dtype=np.float64)
            sizes = np.asarray(f["popsizes"], dtype=np.int64) if "popsizes" in f.files else None
    except (OSError, KeyError, ValueError) as exc:
        raise ValueError(f"history file {str(path)!r} is missing or damaged ({exc})") from exc
    if sizes is None:  # written before restarts: one row per generation
        if fitness.ndim != 2 or fitness.shape[0] < n or fitness.shape[1] != popsize:
            raise ValueError(f"history file {str(path)!r} holds {fitness.shape} fitness values; the checkpoint "
                             f"needs ({n}, {popsize})")
        return [fitness[g] for g in range(n)]
    if fitness.ndim != 1 or sizes.ndim != 1 or len(sizes) < n or np.any(sizes < 1) \
            or int(sizes.sum()) != len(fitness):
        raise ValueError(f"history file {str(path)!r} is damaged: {len(fitness)} fitness values for population "
                         f"sizes summing to {int(sizes.sum()) if sizes.ndim == 1 else sizes.shape}; the checkpoint "
                         f"needs {n} generations")
    ends = np.cumsum(sizes)
    return [fitness[ends[g] - sizes[g]:ends[g]] for g in range(n)]


def train(cfg: CMAConfig, out: str | Path, resume: bool = False,
          on_generation: Callable[[list], None] | None = None, checkpoint_every: int = 10) -> dict:
    """Run (or, with resume=True and a checkpoint in `out`, continue) a CMA-ES run; returns the summary.

    A finished run asked for no more generations is not replayed: its summary is returned as it is (so the
    documented loops over seeds can be rerun cheaply after an interruption)."""
    out = Path(out)
    has_ckpt = (out / "checkpoint.json").exists()
    if resume and has_ckpt and (out / "summary.json").exists():
        data = read_versioned_json(out / "checkpoint.json", "cma_checkpoint")
        saved = CMAConfig.from_dict(data["config"]).to_dict()
        same = all(saved[k] == v for k, v in cfg.to_dict().items() if k not in STOPPING_RULES)
        spent = data.get("budget_spent")  # checkpoints before restarts: a run ends after `generations`
        if same and (int(data["generation"]) >= cfg.generations if spent is None else spent >= cfg.budget):
            from mahn_evo.storage.files import read_json_object

            return read_json_object(out / "summary.json", "summary")
    return DirectCMA(cfg, out, resume=resume and has_ckpt).run(on_generation, checkpoint_every)
