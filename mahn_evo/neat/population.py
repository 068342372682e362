"""The NEAT population and its generation loop, as an ask/tell pair.

Why ask/tell: the trainer evaluates a whole generation in one batched, compiled call, so the population never
calls an evaluator itself::

    pop = Population.create(NeatSettings(), seed=1, kind="iros2011", n_inputs=6)
    for _ in range(generations):
        fitness = evaluate_batch(pop.ask())   # list[Genome] -> array (population_size,)
        stats = pop.tell(fitness)             # reproduce; pop.ask() now returns the next generation

``tell`` runs the original's generation (SharpNEAT 1.0, see ``docs/original-system.md``) as named steps, in this
order: rank each species' members, record the best, update species stagnation, species target and elite sizes,
drop species with target 0, make offspring (asexual, then sexual; the innovation tables are cleared first), trim
species to their elites, place the offspring (parent species first), and adjust the threshold, re-speciating fully
if it moved or mean complexity changed by more than 5 %.  With ``population_stagnation_generations`` > 0 (off in
the original) a population whose best has not improved for more than that many generations gives its whole target
to the two best species (NEAT 2002).

Every random choice is drawn from one ``numpy.random.Generator`` (PCG64), species are processed in id order and
the population size never changes, so a seed determines the whole run; :meth:`to_dict` captures the complete state
(RNG included) as plain JSON so a resumed run continues bit-identically.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np

from ..storage.migrate import FORMAT_VERSION, POPULATION_FORMAT, upgrade_population
from .genome import Genome
from .initial import initial_population
from .innovation import InnovationTracker
from .reproduction import (
    Offspring,
    elite_sizes,
    make_offspring,
    stagnation_adjusted_means,
    target_sizes,
    top_two_targets,
)
from .settings import NeatSettings
from .speciation import RepresentativeIndex, Species, ThresholdController, first_compatible, order_keys, speciate_all

__all__ = ["Population", "GenerationStats"]

FORMAT = POPULATION_FORMAT


@dataclass
class _NextGeneration:
    """The generation :meth:`Population.tell` is building: genomes with their birth generation and parents'
    species ids (aligned), its species, and how many genomes at the front are elites (the rest are offspring)."""

    genomes: list[Genome]
    born: list[int]
    parents: list[tuple[int, ...]]
    species: list[Species]
    n_elite: int = 0


@dataclass(frozen=True)
class GenerationStats:
    """Statistics of one evaluated generation (and the threshold the next one was speciated with)."""

    generation: int  # 0-based index of the evaluated generation
    best_fitness: float
    mean_fitness: float
    best_ever: float
    n_species: int  # species in the evaluated generation
    threshold: float  # compatibility threshold after this generation's adjustment
    mean_complexity: float  # nodes + connections, evaluated generation
    max_complexity: int
    mean_hidden: float
    respeciated: bool  # the next generation was fully re-speciated

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)


class Population:
    """A NEAT population: genomes awaiting evaluation, their species, and everything needed to continue."""

    def __init__(
        self,
        settings: NeatSettings,
        genomes: Sequence[Genome],
        tracker: InnovationTracker,
        rng: np.random.Generator,
    ) -> None:
        """Start from ``genomes`` (usually from :func:`initial_population`); they are speciated at the initial
        threshold.  ``rng`` must be the run's only generator (it is advanced by every later step)."""
        if len(genomes) != settings.reproduction.population_size:
            raise ValueError(
                f"Population: got {len(genomes)} genomes for population_size {settings.reproduction.population_size}"
            )
        self.settings = settings
        self.rng = rng
        self.tracker = tracker
        self.generation = 0
        self._genomes: list[Genome] = list(genomes)
        #: Generation in which each genome of _genomes was made (its age decides ties with tie_break "youngest").
        self._born: list[int] = [0] * len(self._genomes)
        #: Species ids of each genome's parents (empty for the initial genomes), for re-speciation.
        self._parents: list[tuple[int, ...]] = [()] * len(self._genomes)
        self._threshold = ThresholdController(settings.speciation.initial_compatibility_threshold)
        #: Salt of the "random" species order (drawn only in that mode, so other runs keep their random stream).
        self._order_salt: int | None = \
            int(rng.integers(0, 2**63)) if settings.speciation.species_order == "random" else None
        self._species, self._next_species_id = speciate_all(
            self._genomes, self._threshold.threshold, settings, (), 0, 0, order_salt=self._order_salt
        )
        self._ref_complexity = self._mean_complexity(self._genomes)
        self.best_genome: Genome | None = None
        self.best_fitness: float = -math.inf
        #: Generation in which best_fitness last improved (for ``population_stagnation_generations``).
        self.last_improvement = 0

    # ---------------------------------------------------------------------------------------------- building
    @classmethod
    def create(
        cls,
        settings: NeatSettings,
        seed: int,
        kind: str = "minimal",
        n_inputs: int = 6,
        n_outputs: int = 2,
        output_activation: str = "bipolar_sigmoid",
    ) -> Population:
        """A fresh population with its own PCG64 generator seeded with ``seed`` (see :func:`initial_population`)."""
        rng = np.random.Generator(np.random.PCG64(seed))
        genomes, tracker = initial_population(kind, n_inputs, settings, rng, n_outputs, output_activation)
        return cls(settings, genomes, tracker, rng)

    # ---------------------------------------------------------------------------------------------- access
    @property
    def genomes(self) -> list[Genome]:
        """The current generation (to be evaluated), as a new list."""
        return list(self._genomes)

    def ask(self) -> list[Genome]:
        """The genomes to evaluate next (same as :attr:`genomes`)."""
        return list(self._genomes)

    @property
    def species(self) -> tuple[Species, ...]:
        """Current species, in id order (members index :attr:`genomes`)."""
        return tuple(self._species)

    @property
    def threshold(self) -> float:
        return self._threshold.threshold

    @staticmethod
    def _mean_complexity(genomes: Sequence[Genome]) -> float:
        return float(np.mean([g.complexity for g in genomes]))

    # ---------------------------------------------------------------------------------------------- loop
    def tell(self, fitnesses: Sequence[float] | np.ndarray) -> GenerationStats:
        """Give the fitness of every genome of :meth:`ask` (same order); produce the next generation.

        One generation is the sequence of steps below, in the original's order; every random draw happens in
        :meth:`_pardon_champion` (sticky stagnation only), :func:`make_offspring` and :meth:`_place_offspring`,
        in that order, so the order of the steps is part of a run's identity.
        """
        f = self._floored_fitness(fitnesses)
        gen = self.generation
        evaluated = self._genomes
        self._rank_members(f)
        best = self._record_best(f, gen)
        champion = self._update_species_stagnation(f, best, gen)
        targets = self._species_targets(f, champion, gen)
        elites = elite_sizes(targets, np.array([len(sp.members) for sp in self._species], dtype=np.int64),
                             champion, self.settings.selection.elitism_proportion)
        species, targets, elites = self._drop_empty_species(targets, elites)
        offspring = make_offspring(species, evaluated, f, targets, elites, self.rng, self.settings, self.tracker)
        nxt = self._trim_to_elites(species, elites, offspring, gen)
        self._place_offspring(nxt, offspring, gen)
        respeciated = self._adjust_threshold(nxt, gen)
        stats = self._stats(gen, f, best, evaluated, respeciated)
        self._genomes, self._born, self._parents, self._species = nxt.genomes, nxt.born, nxt.parents, nxt.species
        self.generation = gen + 1
        return stats

    # ---------------------------------------------------------------------------------------------- tell's steps
    def _floored_fitness(self, fitnesses: Sequence[float] | np.ndarray) -> np.ndarray:
        """The fitness values checked (one finite value per genome) and raised to ``fitness_floor``: the
        roulettes of selection need every fitness > 0."""
        n = self.settings.reproduction.population_size
        f = np.asarray(fitnesses, dtype=np.float64)
        if f.shape != (n,):
            raise ValueError(f"Population.tell: expected {n} fitness values, got shape {f.shape}")
        if not np.all(np.isfinite(f)):
            raise ValueError("Population.tell: fitness values must be finite")
        return np.maximum(f, self.settings.selection.fitness_floor)

    def _rank_members(self, f: np.ndarray) -> None:
        """Sort every species best first: elites, representatives and parent pools are taken from the front.
        Equal fitness is ordered by ``tie_break`` (youngest first lets equally fit offspring replace old elites on
        a plateau), then by index, so the order never depends on the sort algorithm."""
        born = self._born
        for sp in self._species:
            if self.settings.selection.tie_break == "youngest":
                sp.members.sort(key=lambda i: (-f[i], -born[i], i))
            else:
                sp.members.sort(key=lambda i: (-f[i], i))

    def _record_best(self, f: np.ndarray, gen: int) -> int:
        """The index of this generation's best genome; it becomes the best ever if it beats it (which also restarts
        the population's stagnation clock)."""
        best = int(np.argmax(f))
        if f[best] > self.best_fitness:
            self.best_fitness = float(f[best])
            self.best_genome = self._genomes[best]
            self.last_improvement = gen
        return best

    def _update_species_stagnation(self, f: np.ndarray, best: int, gen: int) -> int:
        """Each species' best and improvement clock; with the "sticky" rule flag species stagnant for good (and
        pardon the champion species).  Returns the champion species' position: it is exempt from penalties and
        always reproduces, so the best genome is never lost."""
        champion = 0
        flagged = False
        for k, sp in enumerate(self._species):
            top = float(f[sp.members[0]])
            if top > sp.best_fitness:
                sp.best_fitness = top
                sp.last_improvement = gen
            elif self.settings.selection.stagnation_rule == "sticky" and gen - sp.last_improvement > \
                    self.settings.selection.stagnation_generations:
                sp.culled = True
                flagged = True
            if best in sp.members:
                champion = k
        if flagged:
            self._pardon_champion(f, float(f[best]), gen)
        return champion

    def _species_targets(self, f: np.ndarray, champion: int, gen: int) -> np.ndarray:
        """How many genomes each species has in the next generation: proportional to its (stagnation-penalised)
        mean fitness; or, when the whole population stagnated (``population_stagnation_generations``, NEAT
        2002), half each for the two best species, whose clocks and the population's then restart."""
        n = self.settings.reproduction.population_size
        means = stagnation_adjusted_means(self._species, f, champion, gen, self.settings)
        ps = self.settings.selection.population_stagnation_generations
        if not (ps > 0 and gen - self.last_improvement > ps):
            return target_sizes(means, champion, n)
        tops = np.array([float(f[sp.members[0]]) for sp in self._species])
        targets = top_two_targets(tops, champion, n)
        for k in np.flatnonzero(targets > 0).tolist():
            self._species[k].last_improvement = gen
        self.last_improvement = gen
        return targets

    def _drop_empty_species(self, targets: np.ndarray, elites: np.ndarray
                            ) -> tuple[list[Species], np.ndarray, np.ndarray]:
        """The species that reproduce (target > 0) with their targets and elite sizes: a species with target 0
        dies out and gives no parents."""
        keep = np.flatnonzero(targets > 0)
        return [self._species[k] for k in keep], targets[keep], elites[keep]

    def _trim_to_elites(self, species: list[Species], elites: np.ndarray, offspring: list[Offspring],
                        gen: int) -> _NextGeneration:
        """The next generation's genomes: each species' elites (species order, best first), then the offspring.
        Only the trimmed species survive, each keeping its id, best and clocks; offspring are placed later."""
        nxt = _NextGeneration([], [], [], [])
        born, parents = self._born, self._parents
        for sp, e in zip(species, elites.tolist()):
            if e == 0:
                continue
            start = len(nxt.genomes)
            nxt.genomes.extend(self._genomes[i] for i in sp.members[:e])
            nxt.born.extend(born[i] for i in sp.members[:e])
            nxt.parents.extend(parents[i] for i in sp.members[:e])
            nxt.species.append(sp.successor(list(range(start, start + e))))
        nxt.n_elite = len(nxt.genomes)
        nxt.genomes.extend(o.genome for o in offspring)
        nxt.born.extend([gen + 1] * len(offspring))
        nxt.parents.extend(tuple(o.parent_species) for o in offspring)
        n = self.settings.reproduction.population_size
        assert len(nxt.genomes) == n, (len(nxt.genomes), n)
        return nxt

    def _place_offspring(self, nxt: _NextGeneration, offspring: list[Offspring], gen: int) -> None:
        """Put each offspring into the first compatible species (its parents' species first, then the species
        order), or found a new species with it.  Representatives are each species' best elite (or its founder)."""
        index = RepresentativeIndex(nxt.genomes, self.settings)
        row_of: dict[int, int] = {}
        for sp in nxt.species:
            row_of[sp.id] = index.add(nxt.genomes[sp.members[0]])
        salt = self._order_salt
        keys = None if salt is None else list(order_keys([sp.id for sp in nxt.species], salt))
        thr = self._threshold.threshold
        for j, o in enumerate(offspring):
            i = nxt.n_elite + j
            d = index.distances(o.genome)
            r = first_compatible(d, thr, [row_of.get(pid, -1) for pid in o.parent_species],
                                 None if keys is None else np.asarray(keys, dtype=np.uint64))
            if r >= 0:
                nxt.species[r].members.append(i)
            else:
                sp = Species(self._next_species_id, [i], gen + 1, -math.inf, gen + 1)
                self._next_species_id += 1
                row_of[sp.id] = index.add(o.genome)
                nxt.species.append(sp)
                if keys is not None:
                    assert salt is not None  # keys exist only when the salt does (set together above)
                    keys.append(order_keys([sp.id], salt)[0])

    def _adjust_threshold(self, nxt: _NextGeneration, gen: int) -> bool:
        """Steer the compatibility threshold towards the target species count; if it moved, or mean complexity
        drifted by more than ``respeciation_complexity_change`` since the last full re-speciation, re-speciate the
        next generation from scratch (placement alone would keep stale species).  Returns whether it did."""
        s = self.settings
        changed = self._threshold.adjust(len(nxt.species), s)
        cplx = self._mean_complexity(nxt.genomes)
        drift = abs(cplx - self._ref_complexity) > s.speciation.respeciation_complexity_change * self._ref_complexity
        if not (changed or drift):
            return False
        nxt.species, self._next_species_id = speciate_all(
            nxt.genomes, self._threshold.threshold, s, nxt.species, gen + 1, self._next_species_id,
            nxt.parents if s.speciation.respeciate_parents_first else (), order_salt=self._order_salt,
        )
        self._ref_complexity = cplx
        return True

    def _stats(self, gen: int, f: np.ndarray, best: int, evaluated: list[Genome],
               respeciated: bool) -> GenerationStats:
        """The evaluated generation's statistics (species as evaluated; threshold as adjusted for the next)."""
        complexities = np.array([g.complexity for g in evaluated])
        return GenerationStats(
            generation=gen,
            best_fitness=float(f[best]),
            mean_fitness=float(np.mean(f)),
            best_ever=self.best_fitness,
            n_species=len(self._species),
            threshold=self._threshold.threshold,
            mean_complexity=float(np.mean(complexities)),
            max_complexity=int(np.max(complexities)),
            mean_hidden=float(np.mean([g.n_hidden for g in evaluated])),
            respeciated=respeciated,
        )

    def _pardon_champion(self, f: np.ndarray, best: float, gen: int) -> None:
        """The original's pardon (stagnation_rule "sticky"): the population always keeps an unflagged champion
        species.  A unique champion species is unflagged; if several champion species are all flagged, one drawn at
        random is.  The pardoned species' improvement clock restarts, so it is not flagged again at once."""
        champions = [sp for sp in self._species if float(f[sp.members[0]]) == best]
        if len(champions) == 1:
            pardoned = champions[0] if champions[0].culled else None
        elif all(sp.culled for sp in champions):
            pardoned = champions[int(self.rng.integers(len(champions)))]
        else:
            pardoned = None
        if pardoned is not None:
            pardoned.culled = False
            pardoned.last_improvement = gen

    # ---------------------------------------------------------------------------------------------- state
    def to_dict(self) -> dict[str, Any]:
        """The complete state as plain JSON-able data (no pickle): resuming from it is bit-identical."""
        return {
            "format": FORMAT,
            "version": FORMAT_VERSION,
            "settings": self.settings.to_dict(),
            "generation": self.generation,
            "genomes": [g.to_dict() for g in self._genomes],
            "born": list(self._born),
            "parents": [list(p) for p in self._parents],
            "species": [sp.to_dict() for sp in self._species],
            "next_species_id": self._next_species_id,
            "threshold": self._threshold.to_dict(),
            "reference_complexity": self._ref_complexity,
            "tracker": self.tracker.to_dict(),
            "rng": _rng_state(self.rng),
            "best_genome": None if self.best_genome is None else self.best_genome.to_dict(),
            "best_fitness": None if self.best_fitness == -math.inf else self.best_fitness,
            "last_improvement": self.last_improvement,
            **({} if self._order_salt is None else {"species_order_salt": self._order_salt}),
        }

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> Population:
        """Restore a population saved by :meth:`to_dict` (e.g. after ``json.loads``); a state of an older format
        version is upgraded first (mahn_evo.storage.migrate)."""
        if data.get("format") != FORMAT:
            raise ValueError(f"Population.from_dict: not a {FORMAT} document (format={data.get('format')!r})")
        data = upgrade_population(data, "Population.from_dict")
        missing = sorted({"born", "parents", "last_improvement"} - set(data))
        if missing:
            raise ValueError(f"Population.from_dict: missing field(s) {missing}")
        settings = NeatSettings.from_mapping(data["settings"])
        self = cls.__new__(cls)
        self.settings = settings
        self.generation = int(data["generation"])
        self._genomes = [Genome.from_dict(g) for g in data["genomes"]]
        if len(self._genomes) != settings.reproduction.population_size:
            raise ValueError("Population.from_dict: genome count does not match population_size")
        born = data["born"]
        if len(born) != len(self._genomes) or not all(isinstance(b, int) and 0 <= b <= self.generation for b in born):
            raise ValueError("Population.from_dict: 'born' must hold one generation (0..generation) per genome")
        self._born = list(born)
        parents = data["parents"]
        if len(parents) != len(self._genomes) or not all(
                isinstance(p, list) and all(isinstance(q, int) for q in p) for p in parents):
            raise ValueError("Population.from_dict: 'parents' must hold a list of species ids per genome")
        self._parents = [tuple(p) for p in parents]
        self._species = [Species.from_dict(d) for d in data["species"]]
        members = sorted(i for sp in self._species for i in sp.members)
        if members != list(range(len(self._genomes))):
            raise ValueError("Population.from_dict: species members must partition the genomes")
        self._next_species_id = int(data["next_species_id"])
        self._threshold = ThresholdController.from_dict(data["threshold"])
        self._ref_complexity = float(data["reference_complexity"])
        self.tracker = InnovationTracker.from_dict(data["tracker"])
        self.rng = _rng_from_state(data["rng"])
        bg = data.get("best_genome")
        self.best_genome = None if bg is None else Genome.from_dict(bg)
        bf = data.get("best_fitness")
        self.best_fitness = -math.inf if bf is None else float(bf)
        self.last_improvement = int(data["last_improvement"])
        salt = data.get("species_order_salt")
        order = settings.speciation.species_order
        if (salt is None) != (order != "random") or not (salt is None or isinstance(salt, int)):
            raise ValueError("Population.from_dict: 'species_order_salt' must be an integer exactly when "
                             f"species_order is 'random' (species_order {order!r}, salt {salt!r})")
        self._order_salt = salt
        return self


def _rng_state(rng: np.random.Generator) -> dict[str, Any]:
    st = rng.bit_generator.state
    if st.get("bit_generator") != "PCG64":
        raise ValueError(f"Population: the run generator must be PCG64, got {st.get('bit_generator')!r}")
    return {
        "bit_generator": "PCG64",
        "state": {"state": int(st["state"]["state"]), "inc": int(st["state"]["inc"])},
        "has_uint32": int(st["has_uint32"]),
        "uinteger": int(st["uinteger"]),
    }


def _rng_from_state(d: dict[str, Any]) -> np.random.Generator:
    if d.get("bit_generator") != "PCG64":
        raise ValueError(f"Population.from_dict: rng must be PCG64, got {d.get('bit_generator')!r}")
    bg = np.random.PCG64()
    # numpy's stubs type this setter with their private TypedDict _PCG64State; the setter checks the dict itself.
    bg.state = d  # type: ignore[assignment]
    return np.random.Generator(bg)
