"""How a generation's teams are scored: one frozen record (`EvaluationSettings`) of the decoding, the map and task,
the episodes and their aggregation, and the rules that check it, written once.

Why a module of its own: a training run's configuration (`EvolutionConfig.evaluation`), the evaluator
(`team_evaluator.TeamEvaluator`), the experiment plans and the baselines' direct-encoding controls all build or
read this record; only the evaluator plays episodes.
"""
from __future__ import annotations

from dataclasses import dataclass, field

from mahn_envs.core import TaskParams
from mahn_envs.core.controller import DECISIONS
from mahn_envs.core.rng import check_seed
from mahn_envs.maps.variants import check_branch

from ..cppn import CPPN_ACTIVATIONS
from .substrate import MODES, SYMMETRIES

#: How a team's fitness is taken from its episodes: "fixed" draws (episode keys 0..K-1 every generation) or fresh
#: draws per generation (keys g*K .. g*K+K-1, the same for every team of generation g: common random numbers).
NOISE_DRAWS = ("fixed", "per_generation")
#: How the K episode fitnesses of a team become its fitness.
AGGREGATES = ("mean", "min", "quantile")


@dataclass(frozen=True)
class EvaluationSettings:
    """How genomes are scored as teams: the decoding, the map and task, the episodes and their aggregation.

    The fields, their names and their defaults are those of a training run's configuration (`EvolutionConfig`,
    which keeps them flat in config.json and builds this record as `EvolutionConfig.evaluation`); the rules that
    check them are written here, once.  Same settings (seed included) -> the same scores.
    """

    #: policy geometry: "situational" (a brain per situation) or "standard" (the signal as an input)
    mode: str = "situational"
    #: a built-in map name or a map JSON file
    map: str = "plus"
    #: the task: episode timing, noise, rule switches
    task: TaskParams = field(default_factory=TaskParams)
    #: episodes per team per generation (keyed, see `noise_draws`)
    episodes: int = 1
    seed: int = 0
    #: run the seed genome's Multiply modules in the CPPN's recursive pass (the original code never did)
    evaluate_modules: bool = True
    #: "recursive" (the original's depth-first pass) or "relax" (its MultipleSteps relaxation)
    cppn_activation: str = "recursive"
    #: how the networks' outputs become actions (mahn_envs.core.controller.DECISIONS): "output" (the original's
    #: winner-take-all on the sigmoids) or "net_input" (on their net inputs: no float32 saturation ties)
    decision: str = "output"
    #: "none" (the paper), "mirror" (robots at -z get the mirror image of the brains painted at +z) or "best" (each
    #: team scored as painted and in both mirror readings, the best counts): see substrate.SYMMETRIES
    symmetry: str = "none"
    noise_draws: str = "fixed"
    aggregate: str = "mean"
    #: the quantile of the episode fitnesses with aggregate "quantile"
    quantile: float = 0.25
    #: also score every team on one noise-free episode (aggregated with the noisy ones): a team must work with and
    #: without noise, instead of relying on noise to get out of a deadlock
    noise_free_episode: bool = False
    #: 0 (the paper): every episode on `map`.  S > 0 (map "plus" only): each keyed episode is played on a plus
    #: variant whose left, top and right arms are the plus map's times factors drawn from [1 - S, 1 + S] per
    #: (seed, episode key) (mahn_envs.maps.variants.spread_variant), so teams are selected for following corridors
    #: rather than for one map's distances; the noise-free episode stays on the plus map itself
    map_spread: float = 0.0
    #: 0 (the paper): side arms at the crossing.  B > 0 cm (map "plus" only): each keyed episode's plus variant also
    #: has its left and right arms leaving the top arm at offsets drawn from [0, B] above the crossing (see
    #: mahn_envs.maps.variants), so a turn cannot rest on both sides of the crossing opening at once
    map_branch: float = 0.0
    #: with map_branch: "both" (each side arm's offset from [0, B]), "one" (a random side at the crossing, the
    #: other from [corridor width, B]: the openings never overlap) or "one_short" (as "one", the raised arm shorter
    #: by its offset, so its post can still be reached by the signal; mahn_envs.maps.variants.spread_variant)
    branch_sides: str = "both"
    #: with map_spread or map_branch: the first N keyed episodes of each generation are played on `map` itself, the
    #: others on variants, so every generation keeps noisy episodes on the map the team was solved on (all-variant
    #: hardening traded plus for the test map: docs/results/experiment_harden_branch/)
    plain_episodes: int = 0
    #: 0 (the paper): every episode in the training protocol.  S > 0: each team also plays S episodes of the
    #: sequential (real-world) protocol per generation (mahn_envs.core.sequential: robots called home one at a
    #: time, placed at home and sent back out, robots that see each other; the task's noise; keys from
    #: SEQUENTIAL_KEY, fresh per generation with per-generation draws; with map_spread or map_branch each on its
    #: key's plus variant), scored by `sequential_fitness` and aggregated with the other episodes.  Why: teams
    #: hardened on noisy training episodes can still fail the noisy sequential protocol, the robustness test
    #: (docs/results/experiment_lifetime_seeds_1_15/)
    sequential_episodes: int = 0
    #: with map_spread or map_branch: the first P of the S sequential episodes of each generation are played on `map`
    #: itself, the others on variants.  Why: in the final populations of hardened runs, teams that succeed in noisy
    #: sequential episodes on the plus variants (and on the test map) mostly fail them on plus, and those that succeed
    #: on plus fail the variants: with every sequential episode on a variant, nothing selects for both
    sequential_plain: int = 0
    #: 0: the variants are met under the task's noise only.  N > 0 (with map_spread or map_branch): each team also
    #: plays N noise-free training episodes per generation on plus variants of keys of their own (CLEAN_VARIANT_KEY,
    #: fresh per generation with per-generation draws), aggregated with the others.  Why: under noise the training
    #: protocol barely separates a team that turns where one side arm opens alone from one that does not (a
    #: non-turner scores 71-101 on a raised-right variant, a turner 47-52) while noise-free it scores 3 against 166,
    #: and hardening lost the turn in 3 of 15 runs (docs/results/turn_probes/)
    noise_free_variants: int = 0

    @property
    def on_variants(self) -> bool:
        """Whether keyed episodes are played on plus variants (map_spread or map_branch) instead of the map."""
        return self.map_spread != 0.0 or self.map_branch != 0.0

    def __post_init__(self) -> None:
        if self.mode not in MODES:
            raise ValueError(f"mode must be one of {MODES}, got {self.mode!r}")
        for name, allowed in (("cppn_activation", CPPN_ACTIVATIONS), ("decision", DECISIONS),
                              ("symmetry", SYMMETRIES), ("noise_draws", NOISE_DRAWS), ("aggregate", AGGREGATES)):
            if getattr(self, name) not in allowed:
                raise ValueError(f"{name} must be one of {allowed}, got {getattr(self, name)!r}")
        if isinstance(self.quantile, bool) or not isinstance(self.quantile, (int, float)) \
                or not 0.0 <= self.quantile <= 1.0:
            raise ValueError(f"quantile must be a number in [0, 1], got {self.quantile!r}")
        if not isinstance(self.noise_free_episode, bool):
            raise TypeError(f"noise_free_episode must be true or false, got {self.noise_free_episode!r}")
        if isinstance(self.map_spread, bool) or not isinstance(self.map_spread, (int, float)) \
                or not 0.0 <= self.map_spread < 1.0:
            raise ValueError(f"map_spread must be a number in [0, 1), got {self.map_spread!r}")
        check_branch(self.map_branch, self.map_spread, self.branch_sides)
        if self.branch_sides != "both" and self.map_branch == 0.0:
            raise ValueError(f"branch_sides {self.branch_sides!r} says how map_branch draws its offsets: it needs "
                             "map_branch > 0")
        if self.map_branch > 0.0 and self.map != "plus":
            raise ValueError(f"map_branch draws variants of the plus map (its side arms' offsets), so it needs map "
                             f"'plus', got map {self.map!r}")
        if self.map_spread > 0.0 and self.map != "plus":
            raise ValueError(f"map_spread draws variants of the plus map (its arm lengths), so it needs map 'plus', "
                             f"got map {self.map!r}")
        _check_on_map_count("plain_episodes", self.plain_episodes, "episodes", self.episodes, "keyed",
                            self.on_variants)
        if self.cppn_activation == "relax" and not self.evaluate_modules:
            raise ValueError("cppn_activation 'relax' always evaluates the Multiply modules (as the original's "
                             "MultipleSteps does): it cannot be combined with evaluate_modules = false")
        if isinstance(self.episodes, bool) or not isinstance(self.episodes, int) or self.episodes < 1:
            raise ValueError(f"episodes must be a positive integer, got {self.episodes!r}")
        if isinstance(self.sequential_episodes, bool) or not isinstance(self.sequential_episodes, int) \
                or self.sequential_episodes < 0:
            raise ValueError(f"sequential_episodes must be a non-negative integer, got {self.sequential_episodes!r}")
        _check_on_map_count("sequential_plain", self.sequential_plain, "sequential_episodes",
                            self.sequential_episodes, "sequential", self.on_variants)
        if isinstance(self.noise_free_variants, bool) or not isinstance(self.noise_free_variants, int) \
                or self.noise_free_variants < 0:
            raise ValueError(f"noise_free_variants must be a non-negative integer, got {self.noise_free_variants!r}")
        if self.noise_free_variants and not self.on_variants:
            raise ValueError("noise_free_variants plays noise-free episodes on plus variants: it needs map_spread or "
                             "map_branch > 0")
        if not isinstance(self.seed, int):  # not numpy ints either: a run's configuration is saved as JSON
            raise TypeError(f"seed must be an integer in [0, 2**64), got {self.seed!r}")
        check_seed(self.seed, "seed")


def _check_on_map_count(field: str, value: object, of_field: str, of_value: int, kind: str, on_variants: bool) -> None:
    """`field` says how many of a generation's `of_field` episodes stay on the map itself: an integer in
    [0, of_value], and only meaningful when the other episodes are on variants (else every episode is on the map)."""
    if isinstance(value, bool) or not isinstance(value, int) or not 0 <= value <= of_value:
        raise ValueError(f"{field} must be an integer in [0, {of_field} = {of_value}], got {value!r}")
    if value and not on_variants:
        raise ValueError(f"{field} keeps some {kind} episodes on the map instead of its variants, so it needs "
                         "map_spread or map_branch > 0 (without them every episode is on the map)")
