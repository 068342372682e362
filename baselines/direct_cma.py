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
  history.npz       the fitness of every candidate so far (generations x popsize)
  log.csv           generation, evaluations, best_fitness, mean_fitness, best_ever, solved, n_solved, sigma,
                    seconds (the columns `baselines.compare.evo_curve` reads; budget = evaluations x ticks x 3)
  best_controllers.json  the best team so far (TeamControllers JSON, with its fitness)
  summary.json      method `cmaes_direct_<mode>`, seed, best fitness, solved, evaluations, wall time
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
from dataclasses import asdict, dataclass, fields
from pathlib import Path
from typing import Any

import numpy as np

from mahn_envs.core.params import TaskParams
from mahn_envs.policies.team_controllers import TeamControllers
from mahn_evo.hyperneat.substrate import MODES, WEIGHT_RANGE, query_layout
from mahn_evo.hyperneat.team_evaluator import EvaluationSettings, TeamEvaluator
from mahn_evo.storage.files import atomic_write_csv, atomic_write_json, read_versioned_json, versioned

from .io import new_run_folder

LOG_HEADER = ["generation", "evaluations", "best_fitness", "mean_fitness", "best_ever", "solved", "n_solved",
              "sigma", "cpu_seconds", "seconds"]
STOPPING_RULES = ("generations",)


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

    def __post_init__(self) -> None:
        if self.mode not in MODES:
            raise ValueError(f"mode must be one of {MODES}, got {self.mode!r}")
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

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> CMAConfig:
        names = {f.name for f in fields(cls)}
        unknown = set(d) - names - {"kind", "version", "method"}
        if unknown:
            raise ValueError(f"unknown CMA-ES setting(s) {sorted(unknown)}; known: {sorted(names)}")
        return cls(**{k: v for k, v in d.items() if k in names})


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

    def _save(self) -> None:
        atomic_write_csv(self.out / "log.csv", self.log_header, self.rows)
        self._checkpoint()

    def run(self, on_generation: Callable[[list], None] | None = None, checkpoint_every: int = 10) -> dict:
        if isinstance(checkpoint_every, bool) or not isinstance(checkpoint_every, int) or checkpoint_every < 1:
            raise ValueError(f"checkpoint_every must be a positive integer, got {checkpoint_every!r}")
        while self.generation < self.cfg.generations:
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
        self.es = self._new_es()
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
        return f"cmaes_direct_{self.cfg.mode}"

    @property
    def generation(self) -> int:
        return len(self.history)

    def _new_es(self) -> Any:
        rng = np.random.default_rng([self.cfg.seed, 0xC3A])
        opts = {"popsize": self.cfg.popsize, "seed": np.nan, "verbose": -9,
                "randn": lambda *shape: rng.standard_normal(shape),
                # the run length is ours (a budget), not CMA-ES's convergence tests
                "maxiter": np.inf, "maxfevals": np.inf, "tolfun": 0, "tolfunhist": 0, "tolx": 0,
                "tolstagnation": np.inf, "tolflatfitness": np.inf, "tolconditioncov": np.inf}
        return self.cma.CMAEvolutionStrategy(np.zeros(self.encoding.n_params), self.cfg.sigma0, opts)

    # ------------------------------------------------------------------ files
    def _checkpoint(self) -> None:
        hist = np.stack(self.history) if self.history else np.zeros((0, self.cfg.popsize))
        tmp = self.out / ".history.tmp.npz"
        np.savez(tmp, fitness=hist)
        tmp.replace(self.out / "history.npz")
        state = {"config": self.cfg.to_dict(), "generation": self.generation, "cma_version": self.cma.__version__,
                 "digest": _digest(self.es), "best_fitness": None if not math.isfinite(self.best_fitness)
                 else self.best_fitness, "first_solved": self.first_solved, "wall_seconds": self.wall,
                 "cpu_seconds": self.cpu, "log": self.rows}
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
        try:
            with np.load(path, allow_pickle=False) as f:
                hist = np.asarray(f["fitness"], dtype=np.float64)
        except (OSError, KeyError, ValueError) as exc:
            raise ValueError(f"history file {str(path)!r} is missing or damaged ({exc})") from exc
        n = int(data["generation"])
        if hist.shape[0] < n or hist.shape[1:] != (self.cfg.popsize,):
            raise ValueError(f"history file {str(path)!r} holds {hist.shape} fitness values; the checkpoint "
                             f"needs ({n}, {self.cfg.popsize})")
        for g in range(n):  # replay: ask, tell the recorded fitness (minimised: negated)
            self._last_asked = self.es.ask()
            self._tell(hist[g])
        if _digest(self.es) != data["digest"]:
            raise ValueError(f"replaying {str(path)!r} did not rebuild the saved CMA-ES state (another numpy / "
                             "BLAS build?); the run cannot be continued bit-identically here")
        try:
            self.history = [hist[g] for g in range(n)]
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
        self.history.append(np.asarray(fitness, dtype=np.float64))
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
        row = [gen, (gen + 1) * self.cfg.popsize * self.cfg.episodes, float(fitness[best]), float(fitness.mean()),
               float(self.best_fitness), bool(solved_mask[best]), int(solved_mask.sum()), float(self.es.sigma),
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
        atomic_write_json(self.out / "summary.json", summary)
        return summary


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
        if same and int(data["generation"]) >= cfg.generations:
            from mahn_evo.storage.files import read_json_object

            return read_json_object(out / "summary.json", "summary")
    return DirectCMA(cfg, out, resume=resume and has_ckpt).run(on_generation, checkpoint_every)
