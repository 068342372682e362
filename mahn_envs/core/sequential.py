"""The sequential (real-world) protocol's rules, and whole sequential episodes in one compiled loop.

The paper tests teams on real robots this way: the robots patrol until all of them stand at a post, then are
called home one at a time in the order they left; a robot that reaches home has its signal cleared, is placed at
home facing the arena, and must go back out to its post; then the next one is called.  Success = every robot
reached its own post, came home on its call and went back out.

The rules are written once here (`SequentialSettings`, `stopped`, `assign_posts`, `call_order`) and used by both
implementations: `mahn_evo.evaluation.protocols.sequential_episode` drives any policy through the PettingZoo env
(either engine; the transfer test uses pymunk with robots that bump into each other), and `run_sequential` plays
B episodes of evolved teams in the batch core (kinematic engine, robots that see each other) so that evolution can
be scored on the protocol it is tested on.  With the same team, seed and engine the two give the same records
(tests/envs/test_sequential_kernel.py).

Why the kinematic engine is enough for training: with the generalisation noise, the published teams succeed as
often in the kinematic engine with robots seeing each other as in pymunk with robot contact (measured on four
lifetime-hardened teams, 10 episodes each: 2/2, 1/1, 9/9, 1/1); whether robots see each other matters more (one
team: 2 of 10 seeing, 8 of 10 blind).

Numba's cache of the kernel is keyed on this file and every project module it imports (mahn_envs.compile_cache), so
a change to a rule in task.py or controller.py recompiles it.
"""
from __future__ import annotations

import math
from dataclasses import astuple, dataclass, replace

import numpy as np
from numba import njit, prange

from .controller import (
    OUT_LANE,
    is_size_9,
    pack_networks,
    remembered_action,
    remembered_actions_16,
)
from .kernels import borrowed, forget_episode_rays, play_tick, sense_tick
from .params import ORIGINAL_MAX_TICKS, TaskParams
from .task import F_SIGNAL, HOME_REACHED, POI_CLOSE, H, V, X, Y, _manhattan

#: a post counts as reached within this Manhattan distance, home within HOME_REACHED (the fitness's radii)
POST_REACHED = POI_CLOSE
#: records per robot: left tick, post, called tick, call end tick (-1: none)
REC_LEFT, REC_POST, REC_CALLED, REC_CALL_END = 0, 1, 2, 3
#: stage flags per robot: reached its post, came home, went back out, stood still when its call timed out
S_POST, S_HOME, S_OUT, S_STOOD = 0, 1, 2, 3


@dataclass(frozen=True)
class SequentialSettings:
    """Timing of the sequential protocol (ticks of 33 ms) and what counts as stopped."""

    patrol_ticks: int = ORIGINAL_MAX_TICKS  # longest wait for every robot to stop at a post (one training episode)
    min_patrol_ticks: int = 150
    return_ticks: int = 1500  # longest wait for a called robot to reach home
    out_ticks: int = 1500  # longest wait for it to be back at its post
    stop_window: int = 30  # a robot is stopped when it moved less than stop_distance over this many ticks
    stop_distance: float = 1.0
    left_distance: float = 5.0  # a robot "left" when it first got this far from its start

    def __post_init__(self) -> None:
        for name in ("patrol_ticks", "min_patrol_ticks", "return_ticks", "out_ticks", "stop_window"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, int) or v < 1:
                raise ValueError(f"SequentialSettings.{name} must be a positive integer, got {v!r}")
        for name in ("stop_distance", "left_distance"):
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
                raise ValueError(f"SequentialSettings.{name} must be a positive number of cm, got {v!r}")

    @property
    def max_ticks(self) -> int:
        """The longest episode: the patrol, then three robots called home and sent back out."""
        return self.patrol_ticks + 3 * (self.return_ticks + self.out_ticks) + 10

    def vector(self) -> np.ndarray:
        return np.asarray(astuple(self), dtype=np.float64)


def sequential_task(params: TaskParams, settings: SequentialSettings) -> TaskParams:
    """The task a sequential episode runs: `params` with robots that see each other, no automatic signal, and
    an episode long enough for the whole protocol (the protocol gives and clears the signals)."""
    total = settings.max_ticks
    return replace(params, max_cycles=total, signal_tick=total - total % 30, sample_period=TaskParams().sample_period,
                   auto_signal=False, robots_see_each_other=True)


# ------------------------------------------------------------------ the rules (Python and the kernel call these)

@njit(cache=True, error_model="numpy")
def stopped(hist, n, r, window, distance):
    """Whether robot r moved less than `distance` over the last `window` of the n ticks played; hist holds the
    positions after each tick in a ring of window + 1 rows (row t % (window + 1) after tick t, t >= 1)."""
    if n <= window:
        return False
    a = (n - window) % (window + 1)
    z = n % (window + 1)
    return math.hypot(hist[a, r, 0] - hist[z, r, 0], hist[a, r, 1] - hist[z, r, 1]) < distance


@njit(cache=True, error_model="numpy")
def assign_posts(xy, pois, post, reached):
    """Each robot's post: the nearest POI (Manhattan, first of equals) to where it stopped (xy (R, 2)), reached
    when nearer than POST_REACHED.  When two robots reached one post, only the first keeps it, and then a robot
    that did not reach its nearest post still claims it from the later ones (the published protocol's rule)."""
    n_robots = xy.shape[0]
    for r in range(n_robots):
        best = 0
        best_d = np.inf
        for p in range(pois.shape[0]):
            d = _manhattan(xy[r, 0], xy[r, 1], pois[p, 0], pois[p, 1])
            if d < best_d:
                best_d = d
                best = p
        post[r] = best
        reached[r] = best_d < POST_REACHED
    shared = False
    for r in range(n_robots):
        for q in range(r):
            shared = shared or (reached[q] and reached[r] and post[q] == post[r])
    if shared:
        for r in range(n_robots):
            for q in range(r):
                if reached[r] and post[q] == post[r]:
                    reached[r] = False


@njit(cache=True, error_model="numpy")
def call_order(left_tick, order):
    """The robots in the order they left (left_tick[r], -1 = never: last), ties by index."""
    n = left_tick.shape[0]
    for r in range(n):
        order[r] = r
    for i in range(1, n):  # insertion sort: stable, n = 3
        j = i
        while j > 0 and _later(left_tick[order[j - 1]], left_tick[order[j]]):
            order[j - 1], order[j] = order[j], order[j - 1]
            j -= 1


@njit(cache=True, error_model="numpy", inline="always")
def _later(a, b):
    """Whether a robot that left at tick a (-1: never) is called after one that left at b."""
    if a < 0:
        return b >= 0
    return b >= 0 and a > b


# ------------------------------------------------------------------ whole episodes in the batch core

@njit(cache=True, error_model="numpy", inline="always")
def _networks(b, seen, nobs, nets, brains, tmp_h, actions, size_9, n_brains):
    """Every robot's action of episode b from the inputs its policy holds (nobs) and the signal they show."""
    n_robots = nobs.shape[1]
    for r in range(n_robots):
        seen[b, r, F_SIGNAL] = 1 if nobs[b, r, 6] > 0.5 else 0
    if size_9:
        remembered_actions_16(b, nobs, seen, F_SIGNAL, n_brains, brains[0], brains[1], brains[2], nets[7],
                              brains[4][b], brains[5][b], brains[6][b], brains[7][b], nets[8])
        for r in range(n_robots):
            actions[b, r] = brains[6][b][r, 2]
    else:
        for r in range(n_robots):
            actions[b, r] = remembered_action(b, r, nobs, seen[b, r, F_SIGNAL], nets[0], nets[1], nets[2],
                                              nets[3], nets[4], nets[5], nets[6], nets[7], tmp_h,
                                              brains[4][b, 0], brains[5][b], brains[6][b], nets[8])


@njit(cache=True, error_model="numpy", inline="always")
def _tick(b, n, state, arena, task, work, nets, brains, seen, nobs, actions, hist, size_9, n_brains):
    """Tick n + 1 of episode b: the networks act on nobs, the core plays the tick, the policy's inputs become the
    tick's observations and the positions go into the ring.  Returns n + 1."""
    _networks(b, seen, nobs, nets, brains, brains[3][b], actions, size_9, n_brains)
    play_tick(b, actions, state, arena, task, work, True)
    pose = state[0]
    obs = state[2]
    n += 1
    row = n % hist.shape[1]
    for r in range(pose.shape[1]):
        for i in range(7):
            nobs[b, r, i] = obs[b, r, i]
        hist[b, row, r, 0] = pose[b, r, X]
        hist[b, row, r, 1] = pose[b, r, Y]
    return n


@njit(cache=True, error_model="numpy", parallel=True)
def run_sequential(state, arena, task, work, nets, brains, settings, starts, can_place, max_lost, records, stages,
                   ticks, cut):
    """Whole sequential episodes, episode b played by team b, spread over the cores.

    `state` must hold the reset state (poses placed, first sensing done) of a task with auto_signal off and
    max_cycles >= settings' max_ticks; `brains` comes from kernels.network_scratch; settings is
    SequentialSettings.vector(); starts (B, R, 2) the start positions; can_place says whether a robot may be
    placed at home (its pose there clears the walls); max_lost (B,) int64: episode b stops as soon as more than
    max_lost[b] of its 3 R stages can no longer be done (3 R: never; a caller that only needs to know whether an
    episode reaches some score, `mahn_evo`'s pruning of mirror readings, stops it there).  Out: records (B, R, 4)
    int64 (REC_*), stages (B, R, 4) bool (S_*), ticks (B,) the ticks played, cut (B,) whether the episode was
    stopped by max_lost (its records and stages are then those of that moment).

    The policy's view follows the env protocol exactly: the networks read the observations the last tick
    returned (nobs), so a call or a cleared signal reaches a robot's network one tick later, and a robot placed
    at home gets its fresh observation at once while the others keep theirs.
    """
    n_ep = state[0].shape[0]
    n_robots = state[0].shape[1]
    size_9 = is_size_9(nets[0])
    if size_9:
        pack_networks(nets[0], nets[1], nets[2], nets[3], nets[4], brains[0], brains[1])
    seen = np.zeros((n_ep, n_robots, 3), dtype=np.uint8)
    nobs = state[2].copy()
    actions = np.zeros((n_ep, n_robots), dtype=np.int64)
    hist = np.zeros((n_ep, int(settings[4]) + 1, n_robots, 2))
    for b in prange(n_ep):
        ticks[b] = _episode(b, state, arena, task, work, nets, brains, settings, starts, can_place, max_lost[b],
                            records, stages, cut, seen, nobs, actions, hist, size_9)


#: phases of a sequential episode (`_episode`): the patrol, a called robot's way home, its way back out, the end
_PATROL, _RETURN, _OUT, _DONE = 0, 1, 2, 3


@njit(cache=True, error_model="numpy")
def _episode(b, state, arena, task, work, nets, brains, settings, starts, can_place, max_lost, records, stages, cut,
             seen, nobs, actions, hist, size_9):
    """Sequential episode b (see run_sequential); returns the ticks it played.

    One loop of ticks whose phase (_PATROL, _RETURN, _OUT) says what the protocol waits for, rather than a loop
    per phase: the tick is then inlined at a single place (measured: 1.9x the robot-steps per second of a tick
    called as a function from three loops, whose argument tuples were copied on every call)."""
    # borrowed groups (kernels.borrowed): the arrays the tick takes out of them carry no reference count to update
    state, arena, task, work = borrowed(state), borrowed(arena), borrowed(task), borrowed(work)
    nets, brains, scratch = borrowed(nets), borrowed(brains), borrowed((seen, nobs, actions, hist))
    seen, nobs, actions, hist = scratch[0], scratch[1], scratch[2], scratch[3]
    pose = state[0]
    obs = state[2]
    rflag = state[4]
    home = arena[4]
    pois = arena[3]
    n_robots = pose.shape[1]
    patrol_ticks = int(settings[0])
    min_patrol = int(settings[1])
    return_ticks = int(settings[2])
    out_ticks = int(settings[3])
    window = int(settings[4])
    stop_distance = settings[5]
    left_distance = settings[6]
    n_brains = nets[0].shape[2]
    xy = np.zeros((n_robots, 2))
    post = np.zeros(n_robots, dtype=np.int64)
    reached = np.zeros(n_robots, dtype=np.bool_)
    order = np.zeros(n_robots, dtype=np.int64)
    left = np.zeros(n_robots, dtype=np.int64)
    lanes = brains[2]
    if size_9:
        for r in range(n_robots):
            for i in range(9):
                lanes[b, r, i] = nets[5][b, r, i]
            for q in range(3):
                lanes[b, r, OUT_LANE + q] = nets[6][b, r, q]
    for r in range(n_robots):
        for j in range(4):
            records[b, r, j] = -1
            stages[b, r, j] = False
    n = 0  # ticks played
    phase = _PATROL
    waited = 0  # ticks of the current phase
    call = -1  # the robot called is order[call] (none during the patrol)
    k = 0
    lost = 0  # stages that can no longer be done: a post not reached, a call home missed (and so its way out)
    cut[b] = False
    while phase != _DONE:
        n = _tick(b, n, state, arena, task, work, nets, brains, seen, nobs, actions, hist, size_9, n_brains)
        waited += 1
        next_call = False
        if phase == _PATROL:  # 1. patrol until every robot has stopped (or time is up)
            for r in range(n_robots):
                if records[b, r, REC_LEFT] < 0 and math.hypot(pose[b, r, X] - starts[b, r, 0],
                                                               pose[b, r, Y] - starts[b, r, 1]) > left_distance:
                    records[b, r, REC_LEFT] = n
            done = waited == patrol_ticks
            if n >= min_patrol and not done:
                done = True
                for r in range(n_robots):
                    if not stopped(hist[b], n, r, window, stop_distance):
                        done = False
                        break
            if done:
                for r in range(n_robots):
                    xy[r, 0] = pose[b, r, X]
                    xy[r, 1] = pose[b, r, Y]
                assign_posts(xy, pois, post, reached)
                for r in range(n_robots):
                    records[b, r, REC_POST] = post[r]
                    stages[b, r, S_POST] = reached[r]
                    left[r] = records[b, r, REC_LEFT]
                    lost += 0 if reached[r] else 1
                call_order(left, order)  # 2. call robots home one at a time, in the order they left
                next_call = True
        elif phase == _RETURN:
            if _manhattan(pose[b, k, X], pose[b, k, Y], home[0], home[1]) <= HOME_REACHED:
                stages[b, k, S_HOME] = True
            if stages[b, k, S_HOME] or waited == return_ticks:
                records[b, k, REC_CALL_END] = n
                stages[b, k, S_STOOD] = not stages[b, k, S_HOME] and stopped(hist[b], n, k, window, stop_distance)
                rflag[b, k, F_SIGNAL] = 0
                obs[b, k, 6] = 0.0
                if stages[b, k, S_HOME]:
                    if can_place:  # placed at home facing the arena (BatchSim.resense for this episode)
                        _place_home(b, k, n, state, arena, task, work)
                    for j in range(7):  # its policy gets its observation now (placed or not), the others keep theirs
                        nobs[b, k, j] = obs[b, k, j]
                    phase = _OUT
                    waited = 0
                else:
                    lost += 2
                    next_call = True
        else:  # _OUT: back out at its post
            if stopped(hist[b], n, k, window, stop_distance) and _manhattan(
                    pose[b, k, X], pose[b, k, Y], pois[post[k], 0], pois[post[k], 1]) < POST_REACHED:
                stages[b, k, S_OUT] = True
                next_call = True
            elif waited == out_ticks:
                lost += 1
                next_call = True
        if lost > max_lost:
            cut[b] = True
            phase = _DONE
        elif next_call:
            call += 1
            if call == n_robots:
                phase = _DONE
            else:
                k = order[call]
                rflag[b, k, F_SIGNAL] = 1  # BatchSim.give_signal: the core's flag and observation, not the policy's
                obs[b, k, 6] = 1.0
                records[b, k, REC_CALLED] = n
                phase = _RETURN
                waited = 0
    return n


@njit(cache=True, error_model="numpy", inline="always")
def _place_home(b, k, n, state, arena, task, work):
    """Robot k of episode b placed at home facing the arena, and the episode sensed again for tick n + 1."""
    pose = state[0]
    home = arena[4]
    pose[b, k, X] = home[0]
    pose[b, k, Y] = home[1]
    pose[b, k, H] = math.pi / 2
    pose[b, k, V] = 0.0
    forget_episode_rays(b, work)
    sense_tick(b, n + 1, state, arena, task, work)


@dataclass
class SequentialRecords:
    """Outcome of B sequential episodes: per robot the REC_* ticks / post (-1: none) and the S_* flags."""

    records: np.ndarray  # (B, R, 4) int64
    stages: np.ndarray  # (B, R, 4) bool
    ticks: np.ndarray  # (B,) int64
    #: (B,) bool: stopped early by run_sequential's max_lost (records and stages as at that moment)
    cut: np.ndarray

    @property
    def stages_completed(self) -> np.ndarray:
        """Stages done per episode, three per robot (post, home, back out)."""
        return self.stages[:, :, :3].sum(axis=(1, 2))

    @property
    def success(self) -> np.ndarray:
        """Whether every robot did all three stages, per episode."""
        return np.asarray(self.stages[:, :, :3].all(axis=(1, 2)))

    @property
    def score(self) -> np.ndarray:
        """The fraction of stages done per episode (the protocol's fitness)."""
        return self.stages_completed / (3 * self.stages.shape[1])


def play_sequential(world, controllers, params: TaskParams | None = None,
                    settings: SequentialSettings | None = None, seed: int = 0,
                    episode_keys=None) -> SequentialRecords:
    """Sequential episodes of evolved teams in the batch core: one team in every episode (`episode_keys`, default
    key 0) or a batch of B teams, team b in episode b (keys default 0..B-1).  `params` is the task's noise and
    reflex; the protocol sets the rest (`sequential_task`)."""
    from .batch import BatchSim

    s = settings if settings is not None else SequentialSettings()
    n_teams = controllers.as_batch().w_ih.shape[0]
    n = len(episode_keys) if episode_keys is not None else n_teams
    sim = BatchSim(world, n, sequential_task(params if params is not None else TaskParams(), s))
    if episode_keys is None and n_teams == 1:
        episode_keys = [0]
    return sim.run_sequential(controllers, seed=seed, episode_keys=episode_keys, settings=s)
