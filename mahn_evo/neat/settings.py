"""Every NEAT parameter, grouped by concern into validated, immutable records, behind one flat surface.

The defaults are the values of the original IROS 2011 system (HyperSharpNEAT, i.e. SharpNEAT 1.0 with changes;
see ``docs/original-system.md`` section 8).  As in SharpNEAT 4, the parameters live in one record per concern
(:class:`ReproductionSettings`, :class:`SelectionSettings`, :class:`MutationSettings`,
:class:`SpeciationSettings`, :class:`InitialisationSettings`, :class:`CppnSettings`), each validating its own
fields, so the code of a NEAT step reads the record of its concern (``settings.mutation.weight_limit``).

Users see one flat table: :class:`NeatSettings` is built from the flat keys (``NeatSettings(population_size=150)``,
the ``[neat]`` table of a configuration file, a saved checkpoint), writes them back flat (:meth:`NeatSettings.to_dict`)
and reads them flat (``settings.population_size``).  A typo fails loudly naming the key instead of silently running
with a default.  Every record is frozen, so a run's configuration can be written to JSON, compared and restored
exactly.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

#: Activation names a hidden node may be given by add-node (see :mod:`mahn_evo.cppn.activations`).
HIDDEN_ACTIVATION_CHOICES = ("bipolar_sigmoid", "gaussian", "abs", "sine", "sigmoid", "error_sign", "identity")
TIE_BREAKS = ("youngest", "oldest")
SPECIES_ORDERS = ("id", "random")
STAGNATION_RULES = ("recompute", "sticky")


def _check(cond: bool, name: str, msg: str) -> None:
    if not cond:
        raise ValueError(f"NeatSettings.{name}: {msg}")


def _is_real(v: Any) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool)


def _check_probabilities(record: Any, *names: str) -> None:
    for name in names:
        v = getattr(record, name)
        _check(_is_real(v) and 0.0 <= v <= 1.0, name, f"must be a number in [0, 1], got {v!r}")


def _check_non_negative(record: Any, *names: str) -> None:
    for name in names:
        v = getattr(record, name)
        _check(_is_real(v) and math.isfinite(v) and v >= 0.0, name, f"must be a finite number >= 0, got {v!r}")


def _check_flags(record: Any, *names: str) -> None:
    for name in names:
        _check(isinstance(getattr(record, name), bool), name, "must be a bool")


def _check_count(value: Any, name: str, minimum: int) -> None:
    _check(isinstance(value, int) and not isinstance(value, bool) and value >= minimum, name,
           f"must be an int >= {minimum}, got {value!r}")


@dataclass(frozen=True)
class ReproductionSettings:
    """How many genomes there are and how offspring are made."""

    #: Nominal population size.  Unlike the original (whose per-species rounding let 200 drift to 186..254), the
    #: population is kept at exactly this size by largest-remainder apportionment of species targets.
    population_size: int = 500
    #: Fraction of a species' offspring made asexually (copy + exactly one mutation); the rest are crossovers.
    asexual_proportion: float = 0.5
    #: Probability that a crossover takes its second parent from the whole population instead of the species.
    interspecies_mating_probability: float = 0.01
    #: Probability of including the less-fit parent's disjoint/excess genes (one coin per mating).
    disjoint_excess_recombine_probability: float = 0.1
    #: Probability that a crossover child also gets one mutation (the mutation roulette).  0 is the original
    #: (SharpNEAT 1.0 never mutates after crossover); NEAT 2002 mutates 80 % of them (mate_only_prob 0.2).
    crossover_mutation_probability: float = 0.0

    def __post_init__(self) -> None:
        _check_count(self.population_size, "population_size", 2)
        _check_probabilities(self, "asexual_proportion", "interspecies_mating_probability",
                             "disjoint_excess_recombine_probability", "crossover_mutation_probability")


@dataclass(frozen=True)
class SelectionSettings:
    """Who survives and who becomes a parent: elitism, the parent pool, ties, fitness floor and stagnation."""

    #: Fraction of a species' target size kept unchanged (elite = floor(target * elitism), see reproduction).
    elitism_proportion: float = 0.2
    #: Parents are drawn only from the best ``round(selection_proportion * size)`` members of a species.
    selection_proportion: float = 0.8
    #: Order of species members of equal fitness.  It decides, on a fitness plateau, which genomes are the elites,
    #: the species representative and the parent pool.  "youngest": newest first, as SharpNEAT 1.0's
    #: GenomeComparer (fitness descending, then genome age ascending), so equally fit offspring replace old elites
    #: and the population drifts neutrally along the plateau.  "oldest": first-born first, which freezes the elites
    #: on a plateau; it was mahn 0.1's rule, and files of format version 1 without this setting used it (see
    #: mahn_evo.storage.migrate).
    tie_break: str = "youngest"
    #: Fitness values are raised to at least this floor (the original's max(F, 1e-7)); roulettes need them > 0.
    fitness_floor: float = 1e-7
    #: A species whose best fitness has not improved for more than this many generations is penalised ...
    stagnation_generations: int = 200
    #: ... by multiplying its mean fitness (used for target sizes) by this factor.  The champion species is exempt.
    stagnation_penalty: float = 0.01
    #: "recompute": a species is penalised in every generation in which it has gone more than
    #: stagnation_generations without improving, and the champion species is always exempt (mahn's rule).
    #: "sticky": the original's rule (SharpNeatLib/Evolution/EvolutionAlgorithm.cs, UpdateSpeciesStats): once
    #: flagged a species stays penalised for good, even if it improves later; a unique champion species that gets
    #: flagged is pardoned and its improvement clock restarts (another stagnation_generations); when several
    #: champion species are all flagged, one drawn at random is pardoned.
    stagnation_rule: str = "recompute"
    #: When > 0: if the best fitness of the whole population has not improved for more than this many generations,
    #: only the two best species reproduce (half the population each) and the counter restarts (NEAT 2002's
    #: rule with 20).  0 (the original) disables it.
    population_stagnation_generations: int = 0

    def __post_init__(self) -> None:
        _check_probabilities(self, "elitism_proportion", "selection_proportion", "stagnation_penalty")
        _check(self.selection_proportion > 0.0, "selection_proportion", "must be > 0")
        _check(self.tie_break in TIE_BREAKS, "tie_break", f"must be one of {TIE_BREAKS}, got {self.tie_break!r}")
        _check_non_negative(self, "fitness_floor")
        _check_count(self.stagnation_generations, "stagnation_generations", 0)
        _check(self.stagnation_rule in STAGNATION_RULES, "stagnation_rule",
               f"must be one of {STAGNATION_RULES}, got {self.stagnation_rule!r}")
        _check_count(self.population_stagnation_generations, "population_stagnation_generations", 0)


@dataclass(frozen=True)
class MutationSettings:
    """The mutation roulette (one operator per asexual offspring) and each operator's parameters.

    Probabilities that form a roulette (operators, weight schemes) need not sum to 1: they are weights, normalised
    when spun, which is how SharpNEAT 1.0 treats them too.
    """

    mutate_weights_probability: float = 0.96
    add_connection_probability: float = 0.03
    add_node_probability: float = 0.01
    #: Weights of the five weight-mutation schemes: (jiggle each p=0.5, jiggle each p=0.1, jiggle one,
    #: reset each p=0.1, reset one).  The 0.5 weight on scheme 4 is the original's.
    weight_scheme_probabilities: tuple[float, float, float, float, float] = (0.125, 0.125, 0.125, 0.5, 0.125)
    #: Per-connection selection probabilities of the proportional schemes 1, 2 and 4.
    weight_scheme_proportions: tuple[float, float, float] = (0.5, 0.1, 0.1)
    #: A jiggle adds U(-weight_jiggle, +weight_jiggle).
    weight_jiggle: float = 0.05
    #: Weights are clamped to [-weight_limit, weight_limit] after a jiggle, and resets draw U(-limit, limit).
    #: 1.5 is the original's connectionWeightRange 3 halved.
    weight_limit: float = 1.5
    #: New connections start at U(-new_connection_weight_range, +...) = range/8 in the original.
    new_connection_weight_range: float = 0.375
    #: Attempts at finding an absent (src, dst) pair before add-connection falls back to a weight mutation.
    add_connection_attempts: int = 5
    #: Recurrent connections and self-loops may be added.  The CPPN activation ignores them (they contribute 0),
    #: but they are part of the genome and of the compatibility distance.
    allow_recurrent: bool = True
    #: Add-node keeps the split connection (a parallel path), as the original does.  False removes it instead
    #: (classic NEAT disables it), which preserves the parent's function better on direct encodings like XOR.
    add_node_keeps_split_connection: bool = True
    #: Activation functions a new hidden node draws from, uniformly.
    hidden_activations: tuple[str, ...] = ("bipolar_sigmoid", "gaussian", "abs", "sine")

    def __post_init__(self) -> None:
        operators = ("mutate_weights_probability", "add_connection_probability", "add_node_probability")
        for name in operators:
            v = getattr(self, name)
            _check(_is_real(v) and v >= 0.0, name, f"must be a number >= 0, got {v!r}")
        _check(sum(getattr(self, name) for name in operators) > 0, "mutate_weights_probability",
               "the mutation roulette weights must not all be 0")
        p = self.weight_scheme_probabilities
        _check(len(p) == 5 and all(_is_real(x) and x >= 0 for x in p) and sum(p) > 0, "weight_scheme_probabilities",
               f"must be 5 non-negative numbers, not all 0, got {p!r}")
        q = self.weight_scheme_proportions
        _check(len(q) == 3 and all(_is_real(x) and 0 <= x <= 1 for x in q), "weight_scheme_proportions",
               f"must be 3 numbers in [0, 1], got {q!r}")
        _check_non_negative(self, "weight_jiggle", "new_connection_weight_range")
        _check(_is_real(self.weight_limit) and 0 < self.weight_limit < math.inf, "weight_limit",
               "must be finite and > 0")
        _check(self.new_connection_weight_range <= self.weight_limit, "new_connection_weight_range",
               "must not exceed weight_limit")
        _check_count(self.add_connection_attempts, "add_connection_attempts", 1)
        _check_flags(self, "allow_recurrent", "add_node_keeps_split_connection")
        _check(isinstance(self.hidden_activations, tuple) and len(self.hidden_activations) > 0
               and all(a in HIDDEN_ACTIVATION_CHOICES for a in self.hidden_activations), "hidden_activations",
               f"must be a non-empty tuple drawn from {HIDDEN_ACTIVATION_CHOICES}, got {self.hidden_activations!r}")


@dataclass(frozen=True)
class SpeciationSettings:
    """The compatibility distance, the dynamic threshold that steers the species count, and re-speciation."""

    disjoint_coefficient: float = 1.0
    excess_coefficient: float = 1.0
    #: Multiplies the SUM (not the mean) of |weight differences| over matching genes, as in the original.
    weight_coefficient: float = 0.05
    #: True: the weight term is weight_coefficient * MEAN |dw| over matching genes (NEAT 2002's W-bar) instead of
    #: the sum.  False is the original.
    weight_difference_mean: bool = False
    #: A full re-speciation first tries the species of a genome's parents (by species id, among the species formed
    #: so far), then every species in order, as SharpNEAT 1.0's RedetermineSpeciation.  False: every species in
    #: order only (mahn 0.1's rule; files of format version 1 without this setting used it, see
    #: mahn_evo.storage.migrate).
    respeciate_parents_first: bool = True
    #: Order in which a genome that fits none of its parents' species tries the other species (offspring placement
    #: and full re-speciation).  "id": oldest species first (mahn's rule; it funnels genomes into old species).
    #: "random": a seeded pseudo-random order that is stable per species id, as the original's, which iterates a
    #: Hashtable keyed by species id (SharpNeatLib/Evolution/Population.cs, AddGenomeToSpeciesTable over
    #: speciesTable.Values): bucket order, unrelated to age.
    species_order: str = "id"
    initial_compatibility_threshold: float = 8.0
    #: Desired species count range; ``None`` means population_size/10 - 2 and population_size/10 (48..50 at 500),
    #: see :attr:`NeatSettings.species_target_range`.
    species_count_min: int | None = None
    species_count_max: int | None = None
    #: A new adjustment starts with delta = max(threshold_delta_min, threshold_delta_proportion * threshold).
    threshold_delta_min: float = 0.1
    threshold_delta_proportion: float = 0.01
    #: The delta grows by this factor while the direction stays the same ...
    threshold_delta_acceleration: float = 1.05
    #: ... and is multiplied by -this factor when the species count overshoots the range.
    threshold_delta_deceleration: float = 0.5
    threshold_floor: float = 0.01
    #: A full re-speciation is forced when mean complexity (nodes + connections) changed by more than this
    #: fraction since the last one.
    respeciation_complexity_change: float = 0.05

    def __post_init__(self) -> None:
        _check_non_negative(self, "disjoint_coefficient", "excess_coefficient", "weight_coefficient",
                            "threshold_delta_min", "threshold_delta_proportion", "respeciation_complexity_change")
        _check_flags(self, "weight_difference_mean", "respeciate_parents_first")
        _check(self.species_order in SPECIES_ORDERS, "species_order",
               f"must be one of {SPECIES_ORDERS}, got {self.species_order!r}")
        _check(_is_real(self.initial_compatibility_threshold) and self.initial_compatibility_threshold > 0,
               "initial_compatibility_threshold", "must be > 0")
        _check(_is_real(self.threshold_floor) and self.threshold_floor > 0, "threshold_floor", "must be > 0")
        _check(_is_real(self.threshold_delta_acceleration) and self.threshold_delta_acceleration >= 1.0,
               "threshold_delta_acceleration", "must be >= 1")
        _check(_is_real(self.threshold_delta_deceleration) and 0.0 < self.threshold_delta_deceleration <= 1.0,
               "threshold_delta_deceleration", "must be in (0, 1]")
        for name in ("species_count_min", "species_count_max"):
            v = getattr(self, name)
            _check(v is None or (isinstance(v, int) and v >= 1), name, f"must be an int >= 1, got {v!r}")


@dataclass(frozen=True)
class InitialisationSettings:
    """The weights of the first generation (the genomes themselves come from mahn_evo.neat.initial)."""

    #: Seeded populations: every weight of genomes 1..N-1 gets U(-jitter, +jitter), unclamped (original).
    initial_weight_jitter: float = 0.1
    #: Minimal populations: initial weights U(-initial_weight_range, +initial_weight_range).
    initial_weight_range: float = 1.5

    def __post_init__(self) -> None:
        _check_non_negative(self, "initial_weight_jitter", "initial_weight_range")


@dataclass(frozen=True)
class CppnSettings:
    """How a genome's CPPN is activated, as far as NEAT records it.  The trainer reads the top-level
    ``evaluate_modules`` of its configuration instead (see mahn_evo.training.config), so there this stays False."""

    #: False reproduces the original (module outputs are always 0, so the seed's Multiply modules are dead);
    #: True evaluates Multiply modules, the "intended behaviour" ablation.
    evaluate_modules: bool = False

    def __post_init__(self) -> None:
        _check_flags(self, "evaluate_modules")


#: The concern records of NeatSettings, by attribute name, in the order of the flat table.
CONCERNS: dict[str, type] = {
    "reproduction": ReproductionSettings,
    "selection": SelectionSettings,
    "mutation": MutationSettings,
    "speciation": SpeciationSettings,
    "initialisation": InitialisationSettings,
    "cppn": CppnSettings,
}
#: Flat key -> the concern record that holds it.
CONCERN_OF: dict[str, str] = {f.name: concern for concern, cls in CONCERNS.items() for f in dataclasses.fields(cls)}


@dataclass(frozen=True, init=False)
class NeatSettings:
    """All NEAT parameters: one record per concern, built and read through the flat keys.

    ``NeatSettings(population_size=150, tie_break="oldest")`` routes each key to its record (which validates it);
    ``settings.population_size`` reads it back.  Records may also be passed whole
    (``NeatSettings(mutation=MutationSettings(...))``, which ``dataclasses.replace`` does).  Defaults reproduce the
    original system.
    """

    reproduction: ReproductionSettings
    selection: SelectionSettings
    mutation: MutationSettings
    speciation: SpeciationSettings
    initialisation: InitialisationSettings
    cppn: CppnSettings

    def __init__(self, **settings: Any) -> None:
        unknown = sorted(set(settings) - set(CONCERN_OF) - set(CONCERNS))
        if unknown:
            raise TypeError(f"NeatSettings: unknown setting(s) {', '.join(unknown)}")
        for concern, cls in CONCERNS.items():
            flat = {k: v for k, v in settings.items() if CONCERN_OF.get(k) == concern}
            if concern in settings:
                record = settings[concern]
                if not isinstance(record, cls):
                    raise TypeError(f"NeatSettings.{concern}: must be a {cls.__name__}, got {record!r}")
                if flat:
                    raise TypeError(f"NeatSettings: {sorted(flat)} given both flat and inside {concern}")
            else:
                record = cls(**flat)
            object.__setattr__(self, concern, record)
        n = self.reproduction.population_size
        lo, hi = self.species_target_range
        _check(hi >= lo, "species_count_max", f"must be an int >= species_count_min, got {hi!r}")
        _check(hi <= n, "species_count_max", "must not exceed population_size")

    def __getattr__(self, name: str) -> Any:
        """Flat read access (``settings.weight_limit``), the read side of the flat table."""
        concern = CONCERN_OF.get(name)
        if concern is None:
            raise AttributeError(f"'NeatSettings' object has no attribute {name!r}")
        return getattr(object.__getattribute__(self, concern), name)

    # ------------------------------------------------------------------------------------------------------------
    @property
    def species_target_range(self) -> tuple[int, int]:
        """The (min, max) species count the dynamic threshold steers towards (unset ends follow population_size)."""
        n, sp = self.reproduction.population_size, self.speciation
        lo = sp.species_count_min if sp.species_count_min is not None else max(1, n // 10 - 2)
        hi = sp.species_count_max if sp.species_count_max is not None else max(1, n // 10)
        return lo, hi

    def to_dict(self) -> dict[str, Any]:
        """The flat table: a plain JSON-able dict of every setting (tuples become lists)."""
        out: dict[str, Any] = {}
        for concern in CONCERNS:
            record = getattr(self, concern)
            for f in dataclasses.fields(record):
                v = getattr(record, f.name)
                out[f.name] = list(v) if isinstance(v, tuple) else v
        return out

    @classmethod
    def from_mapping(cls, data: Mapping[str, Any]) -> NeatSettings:
        """Build settings from a flat mapping (e.g. parsed JSON or a TOML table); unknown keys are rejected by
        name."""
        unknown = sorted(set(data) - set(CONCERN_OF))
        if unknown:
            raise ValueError(f"NeatSettings: unknown setting(s) {', '.join(unknown)}")
        return cls(**{k: tuple(v) if isinstance(v, list) else v for k, v in data.items()})

    def replace(self, **changes: Any) -> NeatSettings:
        """A copy with some flat settings changed (validated again)."""
        return self.from_mapping({**self.to_dict(), **changes})

