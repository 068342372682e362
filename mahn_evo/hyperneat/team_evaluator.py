"""Team evaluation through the batch core: a whole generation of CPPNs -> controllers -> fitness, in one call.

Decoding is vectorised over the population (substrate.py) and the episodes run in the compiled parallel loop
with the controllers inside, so a generation of 500 teams costs one kernel call per episode.  Nothing is played
twice: identical teams play once (`_distinct`), an episode a team played in the previous generation is remembered
(`_play`; a noise-free episode on the map under any key), and robots that several teams share at the same place (a
genome's mirror readings) play one robot episode (`_play_training`).  What the evaluator does is one frozen record,
`EvaluationSettings` (evaluation_settings.py); a training run builds it from its configuration
(`EvolutionConfig.evaluation`).
"""
from __future__ import annotations

from collections.abc import Hashable, Sequence
from dataclasses import dataclass

import numpy as np

from mahn_envs.core import BatchSim
from mahn_envs.core.params import NOISE_FIELDS
from mahn_envs.core.sequential import SequentialSettings, sequential_task
from mahn_envs.maps import World, load_map
from mahn_envs.maps.variants import spread_variant
from mahn_envs.policies.team_controllers import TeamControllers

from ..cppn import compile_genome
from ..neat.genome import Genome
from .evaluation_settings import EvaluationSettings
from .memo import GenerationMemo, genome_key
from .substrate import READINGS, decode_population, team_reading

#: the first key of the sequential-protocol episodes (below 2**32: start jitter is drawn from the key's low 32 bits)
SEQUENTIAL_KEY = 1 << 31
#: the first key of the noise-free variant episodes (noise_free_variants), beside the keyed and sequential ones
CLEAN_VARIANT_KEY = 3 << 30
#: a successful sequential episode scores as an ideal training episode (one robot to each post and back: 166.5)
SEQUENTIAL_SUCCESS_FITNESS = 166.5


def sequential_fitness(stages_completed: np.ndarray, success: np.ndarray, n_robots: int) -> np.ndarray:
    """A sequential episode's fitness on the training fitness's scale: 100 x the fraction of its 3 R stages done,
    plus the rest of SEQUENTIAL_SUCCESS_FITNESS on success, so that it is above 100 exactly when the episode
    succeeded (as a training episode is above 100 exactly when solved) and partial progress still counts."""
    done = np.asarray(stages_completed, dtype=np.float64) / (3 * n_robots)
    return 100.0 * done + (SEQUENTIAL_SUCCESS_FITNESS - 100.0) * np.asarray(success, dtype=np.float64)


@dataclass
class Evaluation:
    fitness: np.ndarray  # (N,) team fitness: the episodes' fitness aggregated (mean, min or a quantile)
    solved: np.ndarray  # (N,) fraction of episodes solved
    controllers: TeamControllers  # batch (N, R, K, ...)
    #: (N, R, 2) where each robot ends its episodes (x, y in cm, the mean over the team's episodes): the team's
    #: behaviour, which behavioural-diversity selection compares (mahn_evo.training.diversity)
    end_positions: np.ndarray


CONTROLLER_FIELDS = ("w_ih", "w_hh", "w_ho", "b_h", "b_o")


def _rows(ctrl: TeamControllers, rows: np.ndarray) -> TeamControllers:
    """The teams `rows` of a batch, as contiguous arrays for the kernel."""
    return ctrl.map_arrays(lambda a: np.ascontiguousarray(a[rows]))


def team_keys(ctrl: TeamControllers) -> list[bytes]:
    """Per team of a batch, the bit pattern of its controller arrays (float32): equal keys, identical teams."""
    n = ctrl.w_ih.shape[0]
    rows = np.concatenate([np.ascontiguousarray(getattr(ctrl, f), dtype=np.float32).reshape(n, -1)
                           for f in CONTROLLER_FIELDS], axis=1)
    return [rows[i].tobytes() for i in range(n)]


def distinct_teams(ctrl: TeamControllers) -> tuple[np.ndarray, np.ndarray]:
    """(first, index): `first` lists one team of each distinct set of controller arrays (in order of first
    appearance) and team i equals team first[index[i]].  Teams are compared bit for bit (float32 patterns)."""
    return distinct_keys(team_keys(ctrl))


def distinct_keys(keys: Sequence[bytes]) -> tuple[np.ndarray, np.ndarray]:
    """`distinct_teams` of teams given by their `team_keys`."""
    n = len(keys)
    seen: dict[bytes, int] = {}
    first: list[int] = []
    index = np.empty(n, dtype=np.int64)
    for i in range(n):
        key = keys[i]
        j = seen.get(key)
        if j is None:
            j = seen[key] = len(first)
            first.append(i)
        index[i] = j
    return np.array(first, dtype=np.int64), index


def all_robots_mask(n_robots: int) -> int:
    """The bit mask of a team's n robots all playing."""
    return (1 << n_robots) - 1


def robot_episodes(ctrl: TeamControllers) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The fewest robot episodes that play every robot of the batch at its place: (carriers, robots, src).
    Team carriers[c] carries episode c, in which the robots of bit mask robots[c] play; robot r of team t is
    robot r of episode src[t, r].  A robot (its controller arrays, float32 bit patterns, as `team_keys`) met again
    at the same place in a later team is not played again.  In teams in batch order, the first team with a robot
    not played yet carries it."""
    c = ctrl.as_batch()
    n, n_robots = c.w_ih.shape[0], c.n_robots
    rows = np.concatenate([np.ascontiguousarray(getattr(c, f), dtype=np.float32).reshape(n, n_robots, -1)
                           for f in CONTROLLER_FIELDS], axis=2)
    where: dict[tuple[int, bytes], int] = {}
    carriers: list[int] = []
    robots: list[int] = []
    src = np.empty((n, n_robots), dtype=np.int64)
    for t in range(n):
        mine = -1
        for r in range(n_robots):
            k = (r, rows[t, r].tobytes())
            e = where.get(k)
            if e is None:
                if mine < 0:
                    mine = len(carriers)
                    carriers.append(t)
                    robots.append(0)
                robots[mine] |= 1 << r
                e = where[k] = mine
            src[t, r] = e
    return np.array(carriers, dtype=np.int64), np.array(robots, dtype=np.int64), src


class TeamEvaluator:
    """Scores genomes as teams on one map.  Deterministic: episodes are keyed, not drawn from shared state.

    Robust evaluation: with noise in `task`, `episodes` = K > 1 and ``noise_draws="per_generation"`` every team
    of a generation meets the same K noisy episodes (common random numbers: teams are compared on equal luck) and
    each generation meets new ones (a team cannot be selected for one lucky draw); ``aggregate`` "min" or
    "quantile" scores a team by its bad episodes rather than its mean.
    """

    def __init__(self, settings: EvaluationSettings) -> None:
        if not isinstance(settings, EvaluationSettings):
            raise TypeError("TeamEvaluator takes one EvaluationSettings (a run's is EvolutionConfig.evaluation), "
                            f"got {type(settings).__name__} {settings!r}")
        self.settings = settings
        self.world = load_map(settings.map)
        self._sims: dict[int, BatchSim] = {}
        self._clean_sims: dict[int, BatchSim] = {}
        self._sequential_sims: dict[int, BatchSim] = {}
        #: genome -> (the batch it was decoded in, its row)
        self._decoded: GenerationMemo[tuple[TeamControllers, int]] = GenerationMemo()
        self._scores: GenerationMemo[tuple[float, bool, np.ndarray]] = GenerationMemo()

    def decode(self, genomes: Sequence) -> TeamControllers:
        """The genomes' team controllers (a batch, in order).  A genome decoded by the previous call (an elite, a
        duplicate) is not decoded again: decoding is a pure function of its genes (`memo`)."""
        s = self.settings
        self._decoded.next_generation()
        keys = [genome_key(g) for g in genomes]
        todo: dict[Hashable, Genome] = {}
        for key, g in zip(keys, genomes):
            if key not in todo and self._decoded.get(key) is None:
                todo[key] = g
        if todo:
            plans = [compile_genome(g, s.cppn_activation, s.evaluate_modules) for g in todo.values()]
            fresh = decode_population(plans, s.mode, self.world.n_robots, symmetry=s.symmetry)
            for i, key in enumerate(todo):
                self._decoded.put(key, (fresh, i))
        rows: list[tuple[TeamControllers, int]] = []
        for key in keys:
            row = self._decoded.get(key)
            if row is None:  # cannot happen: every key was decoded above or is remembered
                raise RuntimeError("TeamEvaluator.decode: a genome was neither decoded nor remembered")
            rows.append(row)
        w_ih, w_hh, w_ho, b_h, b_o = (np.stack([getattr(batch, f)[i] for batch, i in rows]) for f in CONTROLLER_FIELDS)
        return TeamControllers(w_ih, w_hh, w_ho, b_h, b_o, s.decision)

    def _sim(self, n: int) -> BatchSim:
        if n not in self._sims:
            self._sims = {n: BatchSim(self.world, n, self.settings.task)}
        return self._sims[n]

    def _on_map(self, key: int) -> bool:
        """Whether keyed episode `key` is played on the map itself (else on the key's plus variant)."""
        s = self.settings
        # key % episodes: the episode's place in its generation (keys run generation * K ... + K - 1, or 0 ... K - 1)
        return not s.on_variants or key % s.episodes < s.plain_episodes

    def _keyed_sim(self, key: int, n: int) -> BatchSim:
        """The simulator of keyed episode `key` for n teams: on the map, or with map_spread on the key's variant."""
        if self._on_map(key):
            return self._sim(n)
        return BatchSim(self._variant(key), n, self.settings.task)

    def _memo_key(self, protocol: str, key: int) -> int:
        """The key an episode's outcome depends on, for the memo: -1 (any key) for a noise-free keyed episode on the
        map itself, which draws nothing (every noise level and the start jitter at 0), so it is the same episode
        whatever its key.  Why: with per-generation draws (the hardened preset's noise-free phase) its key changes
        every generation, and the teams carried over (elites, about a fifth of a generation) would play it again."""
        noise_free = all(getattr(self.settings.task, name) == 0.0 for name in NOISE_FIELDS)
        if protocol == "keyed" and noise_free and self._on_map(key):
            return -1
        return key

    def _clean_sim(self, n: int) -> BatchSim:
        if n not in self._clean_sims:
            self._clean_sims = {n: BatchSim(self.world, n, self.settings.task.without_noise())}
        return self._clean_sims[n]

    def _variant(self, key: int) -> World:
        """The plus variant of episode `key` (map_spread, map_branch, branch_sides): keyed, noise-free variant and
        sequential episodes all draw theirs here."""
        s = self.settings
        return spread_variant(s.seed, key, s.map_spread, s.map_branch, s.branch_sides)

    def _keys(self, first: int, k: int, generation: int) -> list[int]:
        """k keys from `first`, the block of `generation` with per-generation draws (else always the first)."""
        start = first + (generation * k if self.settings.noise_draws == "per_generation" else 0)
        return list(range(start, start + k))

    def _clean_variant_sim(self, key: int, n: int) -> BatchSim:
        """The simulator of noise-free variant episode `key` for n teams: the key's plus variant, no noise."""
        return BatchSim(self._variant(key), n, self.settings.task.without_noise())

    def clean_variant_keys(self, generation: int = 0) -> list[int]:
        """The keys of the noise-free variant episodes every team of `generation` plays (noise_free_variants)."""
        return self._keys(CLEAN_VARIANT_KEY, self.settings.noise_free_variants, generation)

    def _sequential_sim(self, key: int, n: int) -> BatchSim:
        """The simulator of sequential-protocol episode `key` for n teams: on the map, or with map_spread or
        map_branch on the key's plus variant, but for the first `sequential_plain` episodes of each generation."""
        s = self.settings
        task = sequential_task(s.task, SequentialSettings())
        # (key - SEQUENTIAL_KEY) % S: the episode's place in its generation's block (see _keys)
        if s.on_variants and (key - SEQUENTIAL_KEY) % s.sequential_episodes >= s.sequential_plain:
            return BatchSim(self._variant(key), n, task)
        if n not in self._sequential_sims:
            self._sequential_sims = {n: BatchSim(self.world, n, task)}
        return self._sequential_sims[n]

    def sequential_keys(self, generation: int = 0) -> list[int]:
        """The keys of the sequential-protocol episodes every team of `generation` plays (sequential_episodes)."""
        return self._keys(SEQUENTIAL_KEY, self.settings.sequential_episodes, generation)

    def episode_keys(self, generation: int = 0) -> list[int]:
        """The keys of the episodes every team of `generation` is scored on."""
        return self._keys(0, self.settings.episodes, generation)

    def score(self, controllers: TeamControllers, generation: int = 0) -> tuple[np.ndarray, np.ndarray]:
        """Aggregated fitness and solved fraction of each team over its keyed episodes (see `outcomes`)."""
        fitness, solved, _ = self.outcomes(controllers, generation)
        return fitness, solved

    def _episodes(self, generation: int) -> list[tuple[str, int]]:
        """(protocol, key) of every episode a team of `generation` plays: the keyed training episodes, the noise-free
        one, the noise-free variant ones, the sequential-protocol ones, in this order (the order of the mean's sum)."""
        s = self.settings
        episodes = [("keyed", key) for key in self.episode_keys(generation)]
        if s.noise_free_episode:
            episodes.append(("clean", 0))
        episodes += [("clean_variant", key) for key in self.clean_variant_keys(generation)]
        episodes += [("sequential", key) for key in self.sequential_keys(generation)]
        return episodes

    def _distinct(self, controllers: TeamControllers) -> tuple[TeamControllers, list[bytes], np.ndarray]:
        """(the distinct teams of a batch, their keys, index): team i of the batch is distinct team index[i].
        Identical teams (elites carried over, duplicate offspring, genomes that decode to the same weights) meet
        the same keyed episodes, so they are played once."""
        ctrl = controllers.as_batch()
        all_keys = team_keys(ctrl)
        first, index = distinct_keys(all_keys)
        if len(first) < ctrl.w_ih.shape[0]:
            ctrl = _rows(ctrl, first)
        return ctrl, [all_keys[i] for i in first], index

    def _play(self, ctrl: TeamControllers, teams: list[bytes], protocol: str, key: int, rows: Sequence[int],
              fits: np.ndarray, solved: np.ndarray, ends: np.ndarray, max_lost: dict[int, int] | None = None
              ) -> list[int]:
        """Episode (protocol, key) of the distinct teams `rows`: its fitness into fits[row], its solved flag and
        end positions added to solved[row] and ends[row].  A team that played this episode in the previous call is
        not played again (`memo`): an episode is a pure function of the controllers, the seed and the key.

        max_lost (sequential episodes only): row -> the most stages its episode may lose before it is stopped
        (`BatchSim.run_sequential`); the rows stopped are returned, and nothing of theirs is recorded."""
        s = self.settings
        todo = []
        memo_key = self._memo_key(protocol, key)
        for i in rows:
            known = self._scores.get((teams[i], protocol, memo_key))
            if known is None:
                todo.append(i)
            else:
                fits[i], was_solved, end = known
                solved[i] += was_solved
                ends[i] += end
        if not todo:
            return []
        n = ctrl.w_ih.shape[0]
        run = ctrl if len(todo) == n else _rows(ctrl, np.array(todo))
        keys = np.full(len(todo), key, dtype=np.int64)
        cut = np.zeros(len(todo), dtype=bool)
        if protocol == "sequential":
            sim = self._sequential_sim(key, len(todo))
            limits = None if max_lost is None else [max_lost[i] for i in todo]
            seq = sim.run_sequential(run, seed=s.seed, episode_keys=keys, max_lost=limits)
            fit_e, ok_e = sequential_fitness(seq.stages_completed, seq.success, ctrl.n_robots), seq.success
            cut = seq.cut
            end_xy = sim.pose[:, :, :2].copy()  # where the episodes left each robot
        else:
            fit_e, ok_e, end_xy = self._play_training(run, protocol, key)
        for j, i in enumerate(todo):
            if cut[j]:
                continue
            fits[i] = fit_e[j]
            solved[i] += ok_e[j]
            ends[i] += end_xy[j]
            self._scores.put((teams[i], protocol, memo_key), (float(fit_e[j]), bool(ok_e[j]), end_xy[j]))
        return [i for j, i in enumerate(todo) if cut[j]]

    def _sim_of(self, protocol: str, key: int, n: int) -> BatchSim:
        """The simulator of training-protocol episode (protocol, key) for n episodes."""
        if protocol == "clean":
            return self._clean_sim(n)
        if protocol == "clean_variant":
            return self._clean_variant_sim(key, n)
        return self._keyed_sim(key, n)

    def _play_training(self, run: TeamControllers, protocol: str, key: int
                       ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(fitness, solved, end positions (n, R, 2)) of the teams `run` in training-protocol episode (protocol,
        key).  With symmetry "best", robots blind to each other play robot episodes (`robot_episodes`): a robot that
        several teams share at the same place (a genome's mirror readings share 4 of their 9) plays once, and each
        team is assembled from its robots' episodes, bit for bit its own episode (BatchSim.score_teams).  Other
        batches share no robots beyond whole teams (played once already), so they skip the search (2-3 ms)."""
        s = self.settings
        n = run.w_ih.shape[0]
        if s.symmetry == "best" and not s.task.robots_see_each_other:
            carriers, robots, src = robot_episodes(run)
            if len(carriers) < n or np.any(robots != all_robots_mask(run.n_robots)):
                sim = self._sim_of(protocol, key, len(carriers))
                played = sim.run_robot_episodes(_rows(run, carriers), robots, seed=s.seed,
                                                episode_keys=np.full(len(carriers), key, dtype=np.int64))
                fit, ok, final = sim.score_teams(played, src)
                return fit, ok, final[:, :, :2]
        sim = self._sim_of(protocol, key, n)
        res = sim.run_controllers(run, seed=s.seed, episode_keys=np.full(n, key, dtype=np.int64))
        return res.fitness, res.solved, sim.pose[:, :, :2].copy()

    def _aggregate(self, fits: np.ndarray) -> np.ndarray:
        """The team fitness from its episodes' (E, n): the mean (summed in episode order, as always: bit-identical
        for old runs), the min or a quantile.  Each is non-decreasing in every episode's fitness, which the
        pruning of `_best_outcomes` relies on."""
        s = self.settings
        if s.aggregate == "min":
            return fits.min(axis=0)
        if s.aggregate == "quantile":
            return np.quantile(fits, s.quantile, axis=0)
        fit = np.zeros(fits.shape[1])
        for e in range(fits.shape[0]):
            fit += fits[e]
        return fit / fits.shape[0]

    def outcomes(self, controllers: TeamControllers, generation: int = 0
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Aggregated fitness, solved fraction and mean end positions (N, R, 2) of each team over its keyed
        episodes.

        Teams whose controllers are identical are run once, and an episode a team already played in the previous
        call is not played again (`_distinct`, `_play`).
        """
        ctrl, teams, index = self._distinct(controllers)
        self._scores.next_generation()
        episodes = self._episodes(generation)
        n = ctrl.w_ih.shape[0]
        fits = np.zeros((len(episodes), n))
        solved = np.zeros(n)
        ends = np.zeros((n, ctrl.n_robots, 2))
        for e, (protocol, key) in enumerate(episodes):
            self._play(ctrl, teams, protocol, key, range(n), fits[e], solved, ends)
        fit = self._aggregate(fits)
        return fit[index], solved[index] / fits.shape[0], ends[index] / fits.shape[0]

    def _best_outcomes(self, batch: TeamControllers, k: int, generation: int = 0
                       ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """`outcomes` of the best of k alternatives of each of N teams (batch rows a * N + i), as (fitness, solved
        fraction, end positions, the chosen alternative): the best fitness, the first alternative on ties.

        Bit-identical to scoring every alternative, cheaper with sequential-protocol episodes (three quarters of a
        robust generation's time with `sequential_episodes`): every alternative plays the training episodes; then
        each team's leader, its alternative with the highest bound (the aggregate with each sequential episode at
        its maximum, SEQUENTIAL_SUCCESS_FITNESS), plays its sequential episodes, and another alternative plays
        each of its own only while its bound still reaches the leader's exact fitness.  An alternative dropped that
        way scores strictly less than the leader (the aggregates are non-decreasing in every episode), so it is
        neither the best nor tied with it.  Measured on a robust generation of the robot-noise experiment: see
        the README's benchmark table.
        """
        ctrl, teams, index = self._distinct(batch)
        self._scores.next_generation()
        episodes = self._episodes(generation)
        n, n_alt = ctrl.w_ih.shape[0], index.shape[0]
        if n_alt % k:
            raise ValueError(f"_best_outcomes: {n_alt} rows are not {k} alternatives of each team")
        n_teams = n_alt // k
        fits = np.zeros((len(episodes), n))
        solved = np.zeros(n)
        ends = np.zeros((n, ctrl.n_robots, 2))
        first_sequential = len(episodes) - self.settings.sequential_episodes
        for e in range(first_sequential):
            protocol, key = episodes[e]
            self._play(ctrl, teams, protocol, key, range(n), fits[e], solved, ends)
        alt = index.reshape(k, n_teams)  # distinct row of alternative a of team i
        known = np.zeros(fits.shape, dtype=bool)
        known[:first_sequential] = True
        dead = np.zeros(n, dtype=bool)  # stopped by max_lost: cannot reach the leader of any team it is part of

        def bound(rows: np.ndarray, e: int | None = None, value: float = 0.0) -> np.ndarray:
            """The rows' aggregate with each unknown sequential episode at its maximum (episode e at value)."""
            f = np.where(known[:, rows], fits[:, rows], SEQUENTIAL_SUCCESS_FITNESS)
            if e is not None:
                f[e] = value
            return np.where(dead[rows], -np.inf, self._aggregate(f))

        leader = alt[np.argmax(bound(alt.ravel()).reshape(k, n_teams), axis=0), np.arange(n_teams)]
        for e in range(first_sequential, len(episodes)):
            protocol, key = episodes[e]
            self._play(ctrl, teams, protocol, key, np.unique(leader).tolist(), fits[e], solved, ends)
            known[e, leader] = True
        lead_fit = self._aggregate(fits[:, leader])
        # an alternative is dropped once its bound is below the leader's fitness (less a margin for the rounding
        # of a quantile's interpolation; the mean and the min are exactly monotonic)
        reach = np.broadcast_to(lead_fit - 1e-9 * (1.0 + np.abs(lead_fit)), (k, n_teams)).ravel()
        n_stages = 3 * ctrl.n_robots
        # the sequential fitness of an episode that lost L stages, at best: L = 0, 1, ... (decreasing)
        best_with = sequential_fitness(n_stages - np.arange(n_stages + 1), np.arange(n_stages + 1) == 0,
                                       ctrl.n_robots)
        for e in range(first_sequential, len(episodes)):
            rows = alt.ravel()
            live = (bound(rows) >= reach) & ~known[e, rows]
            rows, their_reach = rows[live], reach[live]
            if not rows.size:
                continue
            # the most stages episode e may lose while its alternative can still reach its leader; a team that is
            # several teams' alternative gets the largest
            allowed = sum((bound(rows, e, v) >= their_reach).astype(np.int64) for v in best_with) - 1
            max_lost: dict[int, int] = {}
            for row, a in zip(rows.tolist(), allowed.tolist()):
                max_lost[row] = max(a, max_lost.get(row, a))
            todo = sorted(max_lost)
            protocol, key = episodes[e]
            stopped = self._play(ctrl, teams, protocol, key, todo, fits[e], solved, ends, max_lost)
            known[e, todo] = True
            known[e, stopped] = False
            dead[stopped] = True
        complete = np.asarray(known.all(axis=0))
        fit = np.where(complete, self._aggregate(fits), -np.inf)[alt]  # (k, N); dropped alternatives: -inf
        best = np.argmax(fit, axis=0)
        rows = alt[best, np.arange(n_teams)]
        if not complete[rows].all():  # cannot happen: a leader is always played to the end
            raise RuntimeError("_best_outcomes: a team's best alternative was not played to the end")
        return fit[best, np.arange(n_teams)], solved[rows] / fits.shape[0], ends[rows] / fits.shape[0], best

    @property
    def readings(self) -> int:
        """Teams scored per genome: 3 with symmetry "best" (as painted and both mirror readings), else 1."""
        return len(READINGS) if self.settings.symmetry == "best" else 1

    def evaluate(self, genomes: Sequence, generation: int = 0) -> Evaluation:
        controllers = self.decode(genomes)
        if self.settings.symmetry != "best":
            fitness, solved, ends = self.outcomes(controllers, generation)
            return Evaluation(fitness, solved, controllers, ends)
        # every reading of every genome in one batch; a genome counts as its best reading (the first on ties)
        n = len(genomes)
        readings = [team_reading(controllers, r) for r in READINGS]
        w_ih, w_hh, w_ho, b_h, b_o = (np.concatenate([getattr(t, f) for t in readings]) for f in CONTROLLER_FIELDS)
        batch = TeamControllers(w_ih, w_hh, w_ho, b_h, b_o, controllers.decision)
        fitness, solved, ends, best = self._best_outcomes(batch, len(READINGS), generation)
        return Evaluation(fitness, solved, _rows(batch, best * n + np.arange(n)), ends)
