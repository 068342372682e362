"""Compiled batch loops over episodes.  Thin: every rule lives in core.task and core.controller.

Numba's cache of these loops is keyed on this file and every project module it imports, transitively
(mahn_envs.compile_cache, registered when mahn_envs is imported): a change to a rule in task.py, geometry.py or
controller.py recompiles them.

One tick of an episode is written once, `play_tick` (decide every robot's action -> move -> score -> sense
for the next tick), in three parts that the split tick of an external engine calls one by one
(`decide_tick`, its own motion, `finish_tick`).  `step_all` (the env and the RL vector env) plays it with
given actions, `run_random` with random ones.  The trainer's `run_controllers` writes the same tick out in its
own parallel loop body (the same rule functions and memos): the shared tick cost it 7-13% (measured, see there).

The arrays travel in plain tuples, built once by `BatchSim` (numba types a tuple of arrays as fast as the
arrays one by one, a namedtuple more slowly, which the env's per-step calls would feel):
  state  (pose, raw, obs, racc, rflag, goto, est)       the episodes (layout in core.task)
  arena  (walls, boxes, dirs, pois, home)               the map's geometry (core.api.Arena)
  task   (params, seed, keys, gauss, rows)              TaskParams.vector(), the random streams' seed, episode keys,
                                                        and the "khepera" sensor Gaussians of shared keys: episode
                                                        b reads gauss[rows[b]] (-1: none; fill_sensor_gaussians)
  work   (trig, at, others, cand)                       memos and scratch, one row per episode (below)
  nets   (wt_ih, wt_hh, wt_ho, b_h, b_o, hid, out, brain, by_net)  `transposed` controllers, their state and
                                                        decision rule (core.controller.DECISIONS)
  brains (wpack, bpack, lanes, tmp, prev, memo_obs, memo, pending)  packed networks, network scratch, memos
                                                        (`network_scratch`)
  scores (prev_fit, rewards, solved)                    the team fitness so far and its change in the last tick
  result (fitness, solved)                              whole episodes' outcome

`work` (and task's gauss) hold exact memos, pure-function caches that give the same numbers: trig (B, R, 2) cos
and sin of the heading at[b, r, 0], and at[b, r, 1:4] the (x, y, heading) raw[b, r] was cast from, so rays are
cast again only when a robot has moved (or robots see each other); others (B, R, 2) and cand (B, W) are ray-cast
scratch.  Whoever writes raw or changes the geometry clears the memos (`forget_rays`).
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit, prange, types
from numba.core import cgutils
from numba.extending import intrinsic

from .controller import (
    LANES,
    OUT_LANE,
    PENDING,
    is_size_9,
    pack_networks,
    remembered_action,
    remembered_actions_16,
)
from .rng import CH_ACTION, tick_stream, uniform
from .task import (
    E_TICK,
    F_SIGNAL,
    P_MAXT,
    P_PERIOD,
    P_SEE,
    H,
    X,
    Y,
    cast_robot_rays,
    decide_robot_drawn,
    drive_robot,
    encode_episode_with,
    score_tick,
    sensor_gaussian_pair,
    team_fitness,
)

# ------------------------------------------------------------------ one tick of episode b (inlined everywhere)
# These functions are inlined into the parallel loops' bodies, where numba 0.68 sees which arrays a write
# reaches only through indexing of the kernel's argument tuples (`state[0]`, `work[1][b]`): a tuple unpacked
# (`a, b = t`) or built there hides the aliasing, and the parallel loop drops the writes as dead code.  So the
# tuples are indexed, never unpacked, and the loops pass them on as they came.

@njit(cache=True, error_model="numpy", inline="always")
def heading_trig(b, r, h, trig, at):
    """cos and sin of robot r's heading h into trig[b, r], kept while the heading stays the same.  Zero is never
    taken as unchanged (sin(-0.0) is -0.0, and -0.0 == 0.0), nor NaN (never equal)."""
    if not (h == at[b, r, 0] and h != 0.0):
        trig[b, r, 0] = math.cos(h)
        trig[b, r, 1] = math.sin(h)
        at[b, r, 0] = h


@njit(cache=True, error_model="numpy", inline="always")
def decide_tick(b, actions, state, task):
    """Start episode b's tick: advance its clock and turn every robot's action (actions[b, r]) into heading and
    velocity (the reflex included).  Returns the tick."""
    pose = state[0]
    est = state[6]
    tick = est[b, E_TICK] + 1
    est[b, E_TICK] = tick
    stream = tick_stream(task[1], task[2][b], tick)
    for r in range(pose.shape[1]):
        decide_robot_drawn(b, r, actions[b, r], pose, state[1], state[2], task[0], stream)
    return tick


@njit(cache=True, error_model="numpy", inline="always")
def move_tick(b, state, arena, task, work):
    """Drive every robot of episode b straight for one tick under the wall rule."""
    pose = state[0]
    trig = work[0]
    for r in range(pose.shape[1]):
        heading_trig(b, r, pose[b, r, H], trig, work[1])
        drive_robot(b, r, trig[b, r, 0], trig[b, r, 1], pose, state[3], task[0], arena[0], arena[1])


@njit(cache=True, error_model="numpy", inline="always")
def sense_tick(b, tick, state, arena, task, work):
    """Episode b's inputs for tick `tick`: rays (cast again only for robots that moved, unless robots see each
    other, whose rays depend on the others too), then the encoding with its noise."""
    pose = state[0]
    params = task[0]
    trig = work[0]
    at = work[1]
    see = params[P_SEE] > 0.5
    for r in range(pose.shape[1]):
        x = pose[b, r, X]
        y = pose[b, r, Y]
        h = pose[b, r, H]
        if see or not (x == at[b, r, 1] and y == at[b, r, 2] and h == at[b, r, 3] and x != 0.0 and y != 0.0
                       and h != 0.0):
            heading_trig(b, r, h, trig, at)
            cast_robot_rays(b, r, trig[b, r, 0], trig[b, r, 1], pose, state[1], arena[0], arena[1], arena[2],
                            params, work[2][b], work[3][b])
            at[b, r, 1] = x
            at[b, r, 2] = y
            at[b, r, 3] = h
    encode_episode_with(b, tick, state[1], state[2], state[4], params, task[1], task[2][b], task[3], task[4][b])


@njit(cache=True, error_model="numpy", inline="always")
def finish_tick(b, tick, state, arena, task, work, sense):
    """End episode b's tick after motion: the fitness sample (and automatic signal), then, with `sense`, the
    inputs of the next tick."""
    score_tick(b, tick, state[0], state[3], state[4], state[5], state[6], arena[3], arena[4], task[0])
    if sense:
        sense_tick(b, tick + 1, state, arena, task, work)


@njit(cache=True, error_model="numpy", inline="always")
def play_tick(b, actions, state, arena, task, work, sense):
    """One tick of episode b with the actions actions[b, r] decided: decide, move, score, sense.

    Decisions first, then motion: a robot's decision reads only its own inputs, rays and pose, and its noise
    draws are pure functions of (seed, episode, tick, robot, channel), so the order is free.  Returns the tick.
    """
    tick = decide_tick(b, actions, state, task)
    move_tick(b, state, arena, task, work)
    finish_tick(b, tick, state, arena, task, work, sense)
    return tick


@njit(cache=True, error_model="numpy", inline="always")
def episode_fitness(b, state, arena):
    """Episode b's team fitness if it ended now, and `solved`."""
    return team_fitness(b, state[0], state[3], state[4], state[5], state[6], arena[4])


@njit(cache=True, error_model="numpy", inline="always")
def reward_tick(b, state, arena, scores):
    """The team fitness if episode b ended now, its change since the last tick, and `solved`."""
    prev_fit = scores[0]
    fit, ok = episode_fitness(b, state, arena)
    scores[1][b] = fit - prev_fit[b]
    prev_fit[b] = fit
    scores[2][b] = ok


@njit(cache=True, error_model="numpy", inline="always")
def random_actions(b, tick, actions, p_left, p_forward, task):
    """The random team's action source: each robot of episode b draws left, forward or right into actions[b]."""
    for r in range(actions.shape[1]):
        u = uniform(task[1], task[2][b], tick, r, CH_ACTION)
        actions[b, r] = 0 if u < p_left else (1 if u < p_left + p_forward else 2)


# ------------------------------------------------------------------ loops over the episodes
@intrinsic
def borrowed(typingctx, group):
    """The tuple `group` with its arrays borrowed: the same data, shape and strides without an owner (a null
    meminfo), valid while the caller holds the originals.  The serial loops below take their groups this way, so
    the reference counting in the inlined tick (every view, every array taken out of a tuple) compiles to
    nothing instead of atomic updates: the parallel loops' bodies get their arrays the same way from numba."""
    if not isinstance(group, types.BaseTuple):
        return None

    def codegen(context, builder, signature, args):
        out = args[0]
        for i, ty in enumerate(signature.args[0]):
            if isinstance(ty, types.Array):
                ary = context.make_array(ty)(context, builder, builder.extract_value(args[0], i))
                ary.meminfo = cgutils.get_null_value(ary.meminfo.type)
                ary.parent = cgutils.get_null_value(ary.parent.type)
                out = builder.insert_value(out, ary._getvalue(), i)
        return out

    return group(group), codegen


@njit(cache=True, error_model="numpy", inline="always")
def forget_episode_rays(b, work):
    """Clear episode b's memos (after a robot of it was placed anew): its next sensing casts every ray."""
    for r in range(work[1].shape[1]):
        for j in range(work[1].shape[2]):
            work[1][b, r, j] = np.nan
        for j in range(work[0].shape[2]):
            work[0][b, r, j] = 0.0


@njit(cache=True, error_model="numpy")
def forget_rays(work):
    """Clear the memos (after raw was written or the robots were placed anew): the next sensing casts every ray."""
    for b in range(work[1].shape[0]):
        forget_episode_rays(b, work)


@njit(cache=True, error_model="numpy")
def sense_all(tick, state, arena, task, work):
    """Every episode's inputs for tick `tick` (after a reset, or robots placed by hand)."""
    state, arena, task, work = borrowed(state), borrowed(arena), borrowed(task), borrowed(work)
    for b in range(state[0].shape[0]):
        sense_tick(b, tick, state, arena, task, work)


@njit(cache=True, error_model="numpy")
def decide_all(actions, state, task):
    """Start a tick in every episode: advance the clock and turn actions into heading and velocity."""
    state, task = borrowed(state), borrowed(task)
    for b in range(state[0].shape[0]):
        decide_tick(b, actions, state, task)


@njit(cache=True, error_model="numpy")
def finish_all(state, arena, task, work, scores):
    """End a tick in every episode after motion: fitness sample, sensing for the next tick, and the reward."""
    state, arena, task = borrowed(state), borrowed(arena), borrowed(task)
    work, scores = borrowed(work), borrowed(scores)
    est = state[6]
    for b in range(est.shape[0]):
        finish_tick(b, est[b, E_TICK], state, arena, task, work, True)
        reward_tick(b, state, arena, scores)


@njit(cache=True, error_model="numpy")
def step_all(actions, state, arena, task, work, scores):
    """One tick of every episode with given actions (B, R) (the env and RL vector-env path)."""
    state, arena, task = borrowed(state), borrowed(arena), borrowed(task)
    work, scores = borrowed(work), borrowed(scores)
    for b in range(actions.shape[0]):
        play_tick(b, actions, state, arena, task, work, True)
        reward_tick(b, state, arena, scores)


def network_scratch(wt_ih: np.ndarray, n_hidden: int) -> tuple:
    """The `brains` group of `run_controllers` for transposed weights wt_ih (B, R, K, n_in, n_hidden): packed
    networks (`pack_networks`, for the substrate's size) and per episode the network scratch and memos
    (`remembered_action`, `remembered_actions_16`).  (wpack, bpack, lanes, tmp, prev, memo_obs, memo, pending)."""
    B, R, K, n_in = wt_ih.shape[:4]
    n = B if (n_in == 7 and n_hidden == 9) else 1
    return (np.zeros((n, R, K, LANES, LANES), dtype=np.float32), np.zeros((n, R, K, LANES), dtype=np.float32),
            np.zeros((n, R, LANES), dtype=np.float32), np.zeros((B, n_hidden + 3), dtype=np.float32),
            np.zeros((B, R, n_hidden), dtype=np.float32), np.zeros((B, R, n_in), dtype=np.float32),
            np.zeros((B, R, 3), dtype=np.int64), np.zeros((B, R, PENDING), dtype=np.int64))


@njit(cache=True, error_model="numpy", parallel=True)
def run_controllers(state, arena, task, work, nets, brains, result, traj, record, robots, samples, sample):
    """Whole episodes with the controllers in the loop, episodes spread over the cores.

    State arrays must hold the reset state (poses placed, first sensing done); `brains` comes from
    `network_scratch`.  With `record`, traj[b, t] receives (x, y, heading, action) of every robot after tick t
    (t = 0 is the start).

    Robot episodes: only the robots whose bit is set in robots[b] (bit r: robot r; ALL_ROBOTS: every one) decide,
    move and sense in episode b; the others stay where they started.  With robots blind to each other a robot's
    whole episode depends on nothing but its own controller, start and noise draws (keyed by its place r), so a
    team's episode can be assembled from robot episodes played in other teams (`score_teams`).  With `sample`,
    samples[b, s, r] receives robot r's (x, y, heading) at the fitness sample s (tick (s + 1) * period): all the
    team fitness reads of a robot besides its final pose.

    The trainer's loop has its own body instead of `play_tick`: measured against 5e5b9eb (benchmarks/bench_ab.py
    --batch 300 --teams champions, one thread, CPU time), the shared tick in this parallel loop cost 7-13% (per
    tick views of the episode's scratch, an actions array written and read back, a second loop over the robots).
    Here, as at 5e5b9eb, the episode's scratch rows are taken once per episode and each robot's action is decided
    and applied in the same loop; the rules themselves are the same functions (core.task, core.controller), and
    the memos are the same as `move_tick` and `sense_tick` keep (work).
    """
    # The arrays are taken out of the groups by indexing here, before the parallel loop (never unpacked, see
    # above): arrays from outside the parallel loop reach its body without a reference count (numba passes them
    # as plain pointers), so the reference counting in the inlined functions is a null test, not an atomic update.
    pose = state[0]
    raw = state[1]
    obs = state[2]
    racc = state[3]
    rflag = state[4]
    goto = state[5]
    est = state[6]
    walls = arena[0]
    boxes = arena[1]
    dirs = arena[2]
    pois = arena[3]
    home = arena[4]
    params = task[0]
    seed = task[1]
    keys = task[2]
    gauss = task[3]
    gauss_rows = task[4]
    trig_all = work[0]
    at_all = work[1]
    others_all = work[2]
    cand_all = work[3]
    wt_ih = nets[0]
    wt_hh = nets[1]
    wt_ho = nets[2]
    b_h = nets[3]
    b_o = nets[4]
    hid = nets[5]
    out = nets[6]
    brain = nets[7]
    by_net = nets[8]
    wpack = brains[0]
    bpack = brains[1]
    lanes = brains[2]
    tmp_all = brains[3]
    prev_all = brains[4]
    memo_obs_all = brains[5]
    memo_all = brains[6]
    pending_all = brains[7]
    fitness = result[0]
    solved = result[1]
    n_ep = pose.shape[0]
    n_robots = pose.shape[1]
    n_ticks = int(params[P_MAXT])
    see = params[P_SEE] > 0.5
    size_9 = is_size_9(wt_ih)
    n_brains = wt_ih.shape[2]
    period = int(params[P_PERIOD])
    if size_9:
        pack_networks(wt_ih, wt_hh, wt_ho, b_h, b_o, wpack, bpack)
    for b in prange(n_ep):
        mask = robots[b]
        others = others_all[b]
        cand = cand_all[b]
        tmp_h = tmp_all[b]
        prev = prev_all[b]
        prev_0 = prev_all[b, 0]
        pending = pending_all[b]
        memo_obs = memo_obs_all[b]
        memo = memo_all[b]
        trig = trig_all[b]
        at = at_all[b]
        key = keys[b]
        if size_9:
            for r in range(n_robots):
                for i in range(9):
                    lanes[b, r, i] = hid[b, r, i]
                for q in range(3):
                    lanes[b, r, OUT_LANE + q] = out[b, r, q]
        if record:
            for r in range(n_robots):
                traj[b, 0, r, 0] = pose[b, r, X]
                traj[b, 0, r, 1] = pose[b, r, Y]
                traj[b, 0, r, 2] = pose[b, r, H]
                traj[b, 0, r, 3] = -1.0  # no action before the first tick
        for tick in range(1, n_ticks + 1):
            est[b, E_TICK] = tick
            if size_9:  # every robot's network first (they overlap), each robot's action in memo[r, 2]
                remembered_actions_16(b, obs, rflag, F_SIGNAL, n_brains, wpack, bpack, lanes, brain, prev, memo_obs,
                                      memo, pending, by_net, mask)
            stream = tick_stream(seed, key, tick)
            for r in range(n_robots):
                if not (mask >> r) & 1:
                    continue
                if size_9:
                    action = memo[r, 2]
                else:
                    action = remembered_action(b, r, obs, rflag[b, r, F_SIGNAL], wt_ih, wt_hh, wt_ho, b_h, b_o,
                                               hid, out, brain, tmp_h, prev_0, memo_obs, memo, by_net)
                decide_robot_drawn(b, r, action, pose, raw, obs, params, stream)
                if record:
                    traj[b, tick, r, 3] = action
            # `move_tick`, `score_tick`, `sense_tick` of the shared tick, on the episode's memo rows
            for r in range(n_robots):
                if (mask >> r) & 1:
                    heading_trig(b, r, pose[b, r, H], trig_all, at_all)
                    drive_robot(b, r, trig[r, 0], trig[r, 1], pose, racc, params, walls, boxes)
            score_tick(b, tick, pose, racc, rflag, goto, est, pois, home, params)
            if sample and tick % period == 0:
                for r in range(n_robots):
                    samples[b, tick // period - 1, r, 0] = pose[b, r, X]
                    samples[b, tick // period - 1, r, 1] = pose[b, r, Y]
                    samples[b, tick // period - 1, r, 2] = pose[b, r, H]
            if record:
                for r in range(n_robots):
                    traj[b, tick, r, 0] = pose[b, r, X]
                    traj[b, tick, r, 1] = pose[b, r, Y]
                    traj[b, tick, r, 2] = pose[b, r, H]
            if tick < n_ticks:
                for r in range(n_robots):
                    x = pose[b, r, X]
                    y = pose[b, r, Y]
                    h = pose[b, r, H]
                    if not (mask >> r) & 1:
                        continue
                    if see or not (x == at[r, 1] and y == at[r, 2] and h == at[r, 3] and x != 0.0 and y != 0.0
                                   and h != 0.0):
                        heading_trig(b, r, h, trig_all, at_all)
                        cast_robot_rays(b, r, trig[r, 0], trig[r, 1], pose, raw, walls, boxes, dirs, params, others,
                                        cand)
                        at[r, 1] = x
                        at[r, 2] = y
                        at[r, 3] = h
                encode_episode_with(b, tick + 1, raw, obs, rflag, params, seed, key, gauss, gauss_rows[b], mask)
        if size_9:
            for r in range(n_robots):
                for i in range(9):
                    hid[b, r, i] = lanes[b, r, i]
                for q in range(3):
                    out[b, r, q] = lanes[b, r, OUT_LANE + q]
        fit, ok = team_fitness(b, pose, racc, rflag, goto, est, home)
        fitness[b] = fit
        solved[b] = ok


@njit(cache=True, error_model="numpy", parallel=True)
def score_teams(samples, finals, src, state, arena, params, result):
    """The outcome of teams assembled from robot episodes (`run_controllers` with robot masks and `sample`):
    robot r of team t is robot r of episode src[t, r], with its poses at the fitness samples (samples) and at the
    end (finals (B, R, 3)).  Each team is scored by `score_tick` at every sample tick and `team_fitness` at the
    end: the calls its own episode made, with the same poses, so the same numbers bit for bit.  state holds one
    zeroed episode per team (as after a reset) and receives the teams' end state (final poses included)."""
    pose = state[0]
    racc = state[3]
    rflag = state[4]
    goto = state[5]
    est = state[6]
    pois = arena[3]
    home = arena[4]
    fitness = result[0]
    solved = result[1]
    n_ticks = int(params[P_MAXT])
    period = int(params[P_PERIOD])
    n_robots = pose.shape[1]
    for t in prange(src.shape[0]):
        for s in range(n_ticks // period):
            tick = (s + 1) * period
            for r in range(n_robots):
                e = src[t, r]
                pose[t, r, X] = samples[e, s, r, 0]
                pose[t, r, Y] = samples[e, s, r, 1]
                pose[t, r, H] = samples[e, s, r, 2]
            est[t, E_TICK] = tick
            score_tick(t, tick, pose, racc, rflag, goto, est, pois, home, params)
        for r in range(n_robots):
            e = src[t, r]
            pose[t, r, X] = finals[e, r, 0]
            pose[t, r, Y] = finals[e, r, 1]
            pose[t, r, H] = finals[e, r, 2]
        est[t, E_TICK] = n_ticks
        fit, ok = team_fitness(t, pose, racc, rflag, goto, est, home)
        fitness[t] = fit
        solved[t] = ok


@njit(cache=True, error_model="numpy", parallel=True)
def fill_sensor_gaussians(seed, keys, gauss):
    """gauss[k, tick, r, j] = the "khepera" sensor model's standard Gaussian of robot r's sensor j at `tick` of
    the episodes keyed keys[k] (`task.sensor_gaussian_pair`, the same function the episodes would call).

    Why: the draws are pure functions of (seed, key, tick, robot, channel), and a generation plays every team on
    the same keys (common random numbers), so one table per key serves all its episodes.  Computed in the episode,
    a Box-Muller pair (a logarithm, a square root, a sine and cosine) was about 30 ns, 95 of the 126 ns a robot's
    sensing took under the robot noise (measured on one core, Intel Xeon)."""
    n_ticks = gauss.shape[1]
    for i in prange(gauss.shape[0] * n_ticks):
        k = i // n_ticks
        tick = i % n_ticks
        stream = tick_stream(seed, keys[k], tick)
        for r in range(gauss.shape[2]):
            for j in range(0, gauss.shape[3], 2):
                g0, g1 = sensor_gaussian_pair(stream, r, j)
                gauss[k, tick, r, j] = g0
                gauss[k, tick, r, j + 1] = g1


@njit(cache=True, error_model="numpy", parallel=True)
def run_random(state, arena, task, work, p_left, p_forward, result):
    """Whole episodes of a random team (each robot draws left/forward/right every tick), on all cores.

    The random-policy reference for baselines, and the core's raw-throughput benchmark.
    """
    pose = state[0]
    n_ticks = int(task[0][P_MAXT])
    actions = np.zeros((pose.shape[0], pose.shape[1]), dtype=np.int64)
    for b in prange(pose.shape[0]):
        for t in range(1, n_ticks + 1):
            random_actions(b, t, actions, p_left, p_forward, task)
            play_tick(b, actions, state, arena, task, work, t < n_ticks)
        fit, ok = episode_fitness(b, state, arena)
        result[0][b] = fit
        result[1][b] = ok
