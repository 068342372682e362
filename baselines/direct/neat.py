"""Direct-encoding NEAT: mahn's own NEAT evolving the substrate networks themselves, not CPPNs.

The second direct-encoding control of issue 12 (beside CMA-ES, `cmaes.py`).  It keeps everything of the
HyperNEAT trainer but the indirect encoding: the same NEAT code (`mahn_evo.neat.Population`: speciation,
selection, crossover, weight mutation, NeatSettings' values), the same recurrent 7-9-3 networks (6-9-3 per
situation) and the same evaluator (`TeamEvaluator.score`).  So it separates "indirect encoding" from "NEAT's
evolutionary machinery", as CMA-ES separates it from "evolution versus gradients".

Genome -> networks (`SubstrateGenes`): one bias node (id 0), the network inputs (ids 1..7 in standard geometry,
1..6 in situational: no signal input), then for every robot r and brain k (CMA-ES's order) 9 hidden and 3 output
nodes.  A connection gene whose (source, target) is a substrate connection of that robot and brain sets its
weight: bias -> hidden / output are the biases b_h / b_o, input -> hidden w_ih, hidden -> hidden w_hh (the
recurrent links, self-loops included), hidden -> output w_ho; the weight is the gene's times
WEIGHT_RANGE / weight_limit (NEAT's +-1.5 -> the substrate's +-3, HyperNEAT's and CMA-ES's range).  A connection
absent from the genome is 0.  Genes are laid onto the flat parameter vector of `DirectEncoding`, so both controls
decode through the same code and evolve the same 549 (standard) or 1044 (situational) numbers: one network per
robot (and brain), as CMA-ES evolves them.

Start (`start`): "full" (default) gives every genome all substrate connections with NEAT's initial weights
U(-1.5, 1.5); "feedforward" leaves out the recurrent hidden -> hidden links and lets add-connection grow them (NEAT's
complexification; measured short runs in docs/baselines.md).  Add-node is off (probability 0): the substrate has
exactly 9 hidden nodes per network, so a new node could not be run.  Add-connection draws (source, target) among
all nodes, as NEAT does; pairs that are no substrate connection (input -> output, output -> anything, across
robots) become genes that do nothing (NEAT's own code is used as it is, so they are not prevented); with the full
start every substrate connection exists, so add-connection is off there too.  Speciation is NEAT's, but its
compatibility threshold starts at the initial genomes' expected distance (`initial_distance`), not at 8.

Run folder (a pure function of the seed, resumable bit-identically):
  config.json            the settings, with the resolved NEAT settings
  checkpoint.json        versioned, checksummed: the whole NEAT population (RNG included), log, best so far
  log.csv                generation, evaluations, best_fitness, mean_fitness, best_ever, solved, n_solved,
                         n_species, threshold, mean_connections, cpu_seconds, seconds (the columns
                         `baselines.comparison.compare.evo_curve` reads, as `mahn-baselines cmaes` writes them)
  best_controllers.json  the best team so far (TeamControllers JSON and its genome, with its fitness)
  summary.json           method `neat_direct_<mode>`, seed, best fitness, solved, evaluations, robot-steps, times
"""
from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from mahn_envs.core.params import TaskParams
from mahn_envs.policies.team_controllers import N_HIDDEN, N_OUTPUTS, TeamControllers
from mahn_evo.hyperneat.evaluation_settings import EvaluationSettings
from mahn_evo.hyperneat.substrate import MODES, WEIGHT_RANGE
from mahn_evo.hyperneat.team_evaluator import TeamEvaluator
from mahn_evo.neat import Genome, InnovationTracker, NeatSettings, NodeGene, Population
from mahn_evo.storage.files import (
    atomic_write_checked_json,
    atomic_write_json,
    read_checked_json,
    remove_stray_temp_files,
    versioned,
)

from ..io import new_run_folder, settings_from_dict
from .cmaes import DirectEncoding, GenerationLoop

LOG_HEADER = ["generation", "evaluations", "best_fitness", "mean_fitness", "best_ever", "solved", "n_solved",
              "n_species", "threshold", "mean_connections", "cpu_seconds", "seconds"]
STOPPING_RULES = ("generations",)
STARTS = ("full", "feedforward")
#: the NEAT settings this encoding fixes (see the module docstring); --neat may not change them
FIXED_BY_ENCODING = ("population_size", "add_node_probability")


@dataclass
class NeatDirectConfig:
    mode: str = "situational"  #: controller geometry: situational (2 brains per robot) or standard (1)
    generations: int = 100
    popsize: int = 500  #: NEAT's population size (NeatSettings' default, the paper's)
    seed: int = 0
    start: str = "full"  #: initial genomes: every substrate connection, or all but the recurrent hidden links
    map: str = "plus"
    episodes: int = 1  #: episodes per team (the noise-free task: 1 is exact)
    max_cycles: int = 1364
    signal_tick: int = 690
    neat: dict[str, Any] = field(default_factory=dict)  #: NeatSettings overrides (validated by NeatSettings)

    def __post_init__(self) -> None:
        if self.mode not in MODES:
            raise ValueError(f"mode must be one of {MODES}, got {self.mode!r}")
        if self.start not in STARTS:
            raise ValueError(f"start must be one of {STARTS}, got {self.start!r}")
        for name in ("generations", "popsize", "episodes"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, int) or v < 1:
                raise ValueError(f"{name} must be a positive integer, got {v!r}")
        if isinstance(self.seed, bool) or not isinstance(self.seed, int) or self.seed < 0:
            raise ValueError(f"seed must be a non-negative integer, got {self.seed!r}")
        if not isinstance(self.neat, dict):
            raise TypeError(f"neat must be a mapping of NeatSettings fields, got {type(self.neat).__name__}")
        fixed = sorted(set(self.neat) & set(FIXED_BY_ENCODING))
        if fixed:
            raise ValueError(f"neat: {fixed} are set by the direct encoding (population_size is popsize; the "
                             "substrate has a fixed set of hidden nodes, so add-node is off)")
        _ = self.task_params  # validates max_cycles / signal_tick
        _ = self.neat_settings  # validates the overrides, naming the field

    @property
    def task_params(self) -> TaskParams:
        return TaskParams(max_cycles=self.max_cycles, signal_tick=self.signal_tick)

    @property
    def neat_settings(self) -> NeatSettings:
        """NeatSettings' values, but the population size and the structural mutations the encoding fixes: no
        add-node, and no add-connection when every substrate connection is there from the start."""
        fixed: dict[str, Any] = {"population_size": self.popsize, "add_node_probability": 0.0}
        if self.start == "full":
            fixed["add_connection_probability"] = 0.0
        settings = NeatSettings.from_mapping({**fixed, **self.neat})
        if "initial_compatibility_threshold" in self.neat:
            return settings
        return settings.replace(initial_compatibility_threshold=initial_distance(settings, self.n_genes))

    @property
    def n_genes(self) -> int:
        """Connection genes of an initial genome: every substrate connection, or all but the recurrent ones."""
        enc = DirectEncoding(self.mode)
        n_nets = int(np.prod(enc.shapes["w_hh"][:2]))
        return enc.n_params - (n_nets * N_HIDDEN * N_HIDDEN if self.start == "feedforward" else 0)

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> NeatDirectConfig:
        return settings_from_dict(cls, d, "NEAT-direct", derived=("method", "neat_settings"))


def initial_distance(settings: NeatSettings, n_genes: int) -> float:
    """The expected compatibility distance of two initial genomes: their n_genes genes all match, with weights
    U(-r, r) each, so E|w1 - w2| = 2r/3 per gene, summed (NEAT's original rule) or averaged (NEAT 2002's).

    Why the initial threshold starts there and not at NeatSettings' 8: the weight term sums over matching genes,
    and 8 is the scale of CPPNs of a few dozen genes.  Two random genomes of the 1044 substrate connections are
    ~52 apart, so at 8 every genome would be its own species, and the threshold controller (steps of 0.1, growing
    5 % a generation) would need ~60 generations to reach the range of its target species count; measured in
    docs/baselines.md.  The rule (the dynamic threshold steering to population_size/10 species) stays NEAT's."""
    per_gene = settings.weight_coefficient * 2.0 * settings.initial_weight_range / 3.0
    return per_gene if settings.weight_difference_mean else per_gene * n_genes


class SubstrateGenes:
    """NEAT genomes <-> batches of team controllers: node ids, connection genes and their substrate places."""

    def __init__(self, mode: str, n_robots: int = 3) -> None:
        self.encoding = DirectEncoding(mode, n_robots)
        R, K, H, n_in = self.encoding.shapes["w_ih"]
        self.n_inputs = int(self.encoding.mask_ih[0, 0, 0].sum())  # 7 standard, 6 situational (no signal input)
        first_net = 1 + self.n_inputs
        per_net = N_HIDDEN + N_OUTPUTS
        hidden = first_net + per_net * np.arange(R * K).reshape(R, K)[..., None] + np.arange(N_HIDDEN)  # (R, K, 9)
        outputs = first_net + per_net * np.arange(R * K).reshape(R, K)[..., None] + N_HIDDEN + np.arange(N_OUTPUTS)
        self.n_nodes = first_net + per_net * R * K
        nodes = [NodeGene(0, "bias", "null")] + [NodeGene(i, "input", "null") for i in range(1, first_net)]
        for r in range(R):
            for k in range(K):
                nodes += [NodeGene(int(h), "hidden", "sigmoid") for h in hidden[r, k]]
                nodes += [NodeGene(int(o), "output", "sigmoid") for o in outputs[r, k]]
        self.nodes = tuple(nodes)
        # (source, target) of every entry of DirectEncoding's flat parameter vector, in its order
        inputs = 1 + np.arange(n_in)  # input column j is node 1 + j (situational geometry lacks column 6)
        src_ih = np.broadcast_to(inputs, (R, K, H, n_in))[self.encoding.mask_ih]
        dst_ih = np.broadcast_to(hidden[..., None], (R, K, H, n_in))[self.encoding.mask_ih]
        src_hh = np.broadcast_to(hidden[:, :, None, :], (R, K, H, H)).ravel()  # w_hh[target, source]
        dst_hh = np.broadcast_to(hidden[:, :, :, None], (R, K, H, H)).ravel()
        src_ho = np.broadcast_to(hidden[:, :, None, :], (R, K, N_OUTPUTS, H)).ravel()
        dst_ho = np.broadcast_to(outputs[:, :, :, None], (R, K, N_OUTPUTS, H)).ravel()
        self.src = np.concatenate([src_ih, src_hh, src_ho, np.zeros(R * K * (H + N_OUTPUTS), dtype=np.int64)])
        self.dst = np.concatenate([dst_ih, dst_hh, dst_ho, hidden.ravel(), outputs.ravel()])
        assert self.src.size == self.dst.size == self.encoding.n_params
        self.recurrent = np.zeros(self.src.size, dtype=bool)
        self.recurrent[src_ih.size:src_ih.size + src_hh.size] = True
        #: place[source, target]: index into the parameter vector, -1 where the pair is no substrate connection
        self.place = -np.ones((self.n_nodes, self.n_nodes), dtype=np.int64)
        self.place[self.src, self.dst] = np.arange(self.src.size)

    @property
    def n_params(self) -> int:
        return self.encoding.n_params

    def initial_population(self, settings: NeatSettings, start: str,
                           rng: np.random.Generator) -> tuple[list[Genome], InnovationTracker]:
        """`settings.population_size` genomes with the `start` connections, weights U(-r, r) with NEAT's
        initial_weight_range, drawn genome by genome from `rng` (as NEAT's minimal start draws them)."""
        keep = np.ones(self.src.size, dtype=bool) if start == "full" else ~self.recurrent
        src, dst = self.src[keep], self.dst[keep]
        innov = self.n_nodes + np.arange(src.size, dtype=np.int64)  # connection ids follow the node ids
        r = settings.initial_weight_range
        first = Genome(self.nodes, innov, src, dst, rng.uniform(-r, r, src.size))
        genomes = [first] + [first.with_weights(rng.uniform(-r, r, src.size))
                             for _ in range(settings.population_size - 1)]
        return genomes, InnovationTracker(self.n_nodes + src.size)

    def parameters(self, genomes: Sequence[Genome], weight_limit: float) -> tuple[np.ndarray, np.ndarray]:
        """(N, n_params) substrate parameters (0 where a genome has no gene) and each genome's count of genes
        that are substrate connections."""
        x = np.zeros((len(genomes), self.n_params))
        expressed = np.zeros(len(genomes), dtype=np.int64)
        scale = WEIGHT_RANGE / weight_limit
        for n, g in enumerate(genomes):
            where = self.place[g.src, g.dst]  # add-node is off, so every node is one of the substrate's
            ok = where >= 0
            x[n, where[ok]] = g.weight[ok] * scale
            expressed[n] = int(ok.sum())
        return x, expressed

    def decode(self, genomes: Sequence[Genome], weight_limit: float) -> tuple[TeamControllers, np.ndarray]:
        x, expressed = self.parameters(genomes, weight_limit)
        return self.encoding.decode(x), expressed


class DirectNEAT(GenerationLoop):
    """One run in a folder; `DirectNEAT(cfg, out, resume=True)` continues the checkpoint there."""

    log_header = LOG_HEADER

    def __init__(self, cfg: NeatDirectConfig, out: str | Path, resume: bool = False) -> None:
        self.cfg = cfg
        self.out = Path(out)
        self.settings = cfg.neat_settings
        self.evaluator = TeamEvaluator(EvaluationSettings(mode=cfg.mode, map=cfg.map, task=cfg.task_params,
                                                          episodes=cfg.episodes, seed=cfg.seed))
        self.n_robots = self.evaluator.world.n_robots
        self.genes = SubstrateGenes(cfg.mode, self.n_robots)
        self.rows: list[list] = []
        self.best_fitness = -math.inf
        self.first_solved: int | None = None
        self.wall = 0.0
        self.cpu = 0.0  #: CPU-seconds of this process (all threads): the compute-matched budget axis
        if resume:
            remove_stray_temp_files(self.out)
            self._resume(self.out / "checkpoint.json")
        else:
            new_run_folder(self.out, "neat_direct_config", self._config_record())
            rng = np.random.Generator(np.random.PCG64([cfg.seed, 0x9EA7]))
            genomes, tracker = self.genes.initial_population(self.settings, cfg.start, rng)
            self.population = Population(self.settings, genomes, tracker, rng)

    @property
    def method(self) -> str:
        return f"neat_direct_{self.cfg.mode}"

    @property
    def generation(self) -> int:
        return self.population.generation

    def _config_record(self) -> dict[str, Any]:
        return {**self.cfg.to_dict(), "method": self.method, "neat_settings": self.settings.to_dict()}

    # ------------------------------------------------------------------ files
    def _checkpoint(self) -> None:
        state = {"config": self.cfg.to_dict(), "population": self.population.to_dict(),
                 "best_fitness": None if not math.isfinite(self.best_fitness) else self.best_fitness,
                 "first_solved": self.first_solved, "wall_seconds": self.wall, "cpu_seconds": self.cpu,
                 "log": self.rows}
        atomic_write_checked_json(self.out / "checkpoint.json", "neat_direct_checkpoint", state)

    def _resume(self, ckpt: Path) -> None:
        data = read_checked_json(ckpt, "neat_direct_checkpoint")  # a missing, corrupt or edited file: named
        try:
            saved_cfg = NeatDirectConfig.from_dict(data["config"])
        except (KeyError, TypeError, ValueError) as exc:
            raise ValueError(f"checkpoint file {str(ckpt)!r} is damaged or from another format (config: "
                             f"{exc})") from exc
        saved, asked = saved_cfg.to_dict(), self.cfg.to_dict()
        differing = sorted(k for k in asked if k not in STOPPING_RULES and saved[k] != asked[k])
        if differing:
            raise ValueError(f"cannot resume {str(self.out)!r}: settings differ in {differing} (the run was made "
                             f"with {', '.join(f'{k} = {saved[k]!r}' for k in differing)})")
        try:
            self.population = Population.from_dict(data["population"])
            self.best_fitness = -math.inf if data["best_fitness"] is None else float(data["best_fitness"])
            self.first_solved = data["first_solved"]
            self.wall = float(data["wall_seconds"])
            self.cpu = float(data["cpu_seconds"])
            self.rows = data["log"]
            if not isinstance(self.rows, list) or len(self.rows) != self.population.generation or not all(
                    isinstance(r, list) and len(r) == len(LOG_HEADER) for r in self.rows):
                raise TypeError(f"'log' must hold one row of {len(LOG_HEADER)} values per generation")
        except (KeyError, TypeError, ValueError, AttributeError, IndexError) as exc:
            raise ValueError(f"checkpoint file {str(ckpt)!r} is damaged or from another format (missing or bad "
                             f"field: {exc})") from exc
        if self.population.settings != self.settings:
            raise ValueError(f"checkpoint file {str(ckpt)!r} holds a population bred with other NEAT settings "
                             "than its configuration gives (edited by hand?)")
        if saved["generations"] != asked["generations"]:
            atomic_write_json(self.out / "config.json", versioned("neat_direct_config", self._config_record()))

    # ------------------------------------------------------------------ loop
    def step(self) -> list:
        t0, c0 = time.perf_counter(), time.process_time()
        gen = self.generation
        genomes = self.population.ask()
        controllers, expressed = self.genes.decode(genomes, self.settings.weight_limit)
        fitness, solved = self.evaluator.score(controllers, gen)
        best = int(np.argmax(fitness))
        solved_mask = solved >= 1.0
        if fitness[best] > self.best_fitness:
            self.best_fitness = float(fitness[best])
            atomic_write_json(self.out / "best_controllers.json", versioned("neat_direct_best", {
                "method": self.method, "generation": gen, "fitness": self.best_fitness,
                "solved": bool(solved_mask[best]), "controllers": controllers.team(best).to_dict(),
                "genome": genomes[best].to_dict()}))
        if solved_mask.any() and self.first_solved is None:
            self.first_solved = gen
        stats = self.population.tell(fitness)
        seconds = time.perf_counter() - t0
        self.wall += seconds
        self.cpu += time.process_time() - c0
        row = [gen, (gen + 1) * self.cfg.popsize * self.cfg.episodes, float(fitness[best]), float(fitness.mean()),
               float(self.best_fitness), bool(solved_mask[best]), int(solved_mask.sum()), stats.n_species,
               round(stats.threshold, 6), round(float(expressed.mean()), 3), round(self.cpu, 3), round(seconds, 4)]
        self.rows.append(row)
        return row

    def finish(self) -> dict:
        self._save()
        evaluations = self.rows[-1][1] if self.rows else 0
        summary = {"method": self.method, "mode": self.cfg.mode, "seed": self.cfg.seed, "map": self.cfg.map,
                   "generations": self.generation, "population": self.cfg.popsize, "start": self.cfg.start,
                   "n_params": self.genes.n_params,
                   "best_fitness": None if not math.isfinite(self.best_fitness) else self.best_fitness,
                   "solved": self.first_solved is not None, "first_solved_generation": self.first_solved,
                   "evaluations": evaluations, "robot_steps": evaluations * self.cfg.max_cycles * self.n_robots,
                   "wall_seconds": round(self.wall, 3), "cpu_seconds": round(self.cpu, 3)}
        atomic_write_json(self.out / "summary.json", summary)
        return summary


def train(cfg: NeatDirectConfig, out: str | Path, resume: bool = False,
          on_generation: Callable[[list], None] | None = None, checkpoint_every: int = 10) -> dict:
    """Run (or, with resume=True and a checkpoint in `out`, continue) a direct-encoding NEAT run; returns the
    summary.  Resuming a finished run asked for no more generations only rewrites its summary."""
    out = Path(out)
    has_ckpt = (out / "checkpoint.json").exists()
    return DirectNEAT(cfg, out, resume=resume and has_ckpt).run(on_generation, checkpoint_every)
