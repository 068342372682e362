"""Compiled batch loops over episodes.  Thin: every rule lives in core.task and core.controller.

Numba caches these loops keyed on this file only: after changing a rule in task.py, geometry.py or
controller.py, change this file too (even a comment), or the cache keeps running the old compiled rules.

One tick of an episode is written once, `play_tick` (decide every robot's action -> move -> score -> sense
for the next tick), in three parts that the split tick of an external engine calls one by one
(`decide_tick`, its own motion, `finish_tick`).  The loops differ only in where the actions come from:
given (`step_all`, the env and the RL vector env), drawn at random (`run_random`) or from the networks
(`run_controllers`, the trainer).

The arrays travel in plain tuples, built once by `BatchSim` (numba types a tuple of arrays as fast as the
arrays one by one, a namedtuple more slowly, which the env's per-step calls would feel):
  state  (pose, raw, obs, racc, rflag, goto, est)       the episodes (layout in core.task)
  arena  (walls, boxes, dirs, pois, home)               the map's geometry (core.api.Arena)
  task   (params, seed, keys)                           TaskParams.vector(), the random streams' seed, episode keys
  work   (trig, at, others, cand)                       memos and scratch, one row per episode (below)
  nets   (wt_ih, wt_hh, wt_ho, b_h, b_o, hid, out, brain)  `transposed` controllers and their state
  scores (prev_fit, rewards, solved)                    the team fitness so far and its change in the last tick
  result (fitness, solved)                              whole episodes' outcome

`work` holds exact memos, pure-function caches that give the same numbers: trig (B, R, 2) cos and sin of the
heading at[b, r, 0], and at[b, r, 1:4] the (x, y, heading) raw[b, r] was cast from, so rays are cast again
only when a robot has moved (or robots see each other); others (B, R, 2) and cand (B, W) are ray-cast
scratch.  Whoever writes raw or changes the geometry clears the memos (`forget_rays`).
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from .controller import LANES, OUT_LANE, is_size_9, pack_networks, remembered_action, remembered_action_16
from .rng import CH_ACTION, uniform
from .task import (
    E_TICK,
    F_SIGNAL,
    P_MAXT,
    P_SEE,
    H,
    X,
    Y,
    cast_robot_rays,
    decide_robot,
    drive_robot,
    encode_episode,
    score_tick,
    team_fitness,
)


# ------------------------------------------------------------------ one tick of episode b (inlined everywhere)
@njit(cache=True, error_model="numpy", inline="always")
def episode_work(work, b):
    """Episode b's rows of the memos and scratch: (trig, at, others, cand), each one episode's view."""
    trig, at, others, cand = work
    return trig[b], at[b], others[b], cand[b]


@njit(cache=True, error_model="numpy", inline="always")
def heading_trig(r, h, trig, at):
    """cos and sin of robot r's heading h into trig[r], kept while the heading stays the same.  Zero is never
    taken as unchanged (sin(-0.0) is -0.0, and -0.0 == 0.0), nor NaN (never equal)."""
    if not (h == at[r, 0] and h != 0.0):
        trig[r, 0] = math.cos(h)
        trig[r, 1] = math.sin(h)
        at[r, 0] = h


@njit(cache=True, error_model="numpy", inline="always")
def decide_tick(b, actions, state, task):
    """Start episode b's tick: advance its clock and turn every robot's action (actions[b, r]) into heading and
    velocity (the reflex included).  Returns the tick."""
    pose, raw, _, _, _, _, est = state
    params, seed, keys = task
    tick = est[b, E_TICK] + 1
    est[b, E_TICK] = tick
    for r in range(pose.shape[1]):
        decide_robot(b, r, actions[b, r], tick, pose, raw, params, seed, keys[b])
    return tick


@njit(cache=True, error_model="numpy", inline="always")
def move_tick(b, state, arena, task, ew):
    """Drive every robot of episode b straight for one tick under the wall rule."""
    pose, _, _, racc, _, _, _ = state
    walls, boxes, _, _, _ = arena
    params = task[0]
    trig, at, _, _ = ew
    for r in range(pose.shape[1]):
        heading_trig(r, pose[b, r, H], trig, at)
        drive_robot(b, r, trig[r, 0], trig[r, 1], pose, racc, params, walls, boxes)


@njit(cache=True, error_model="numpy", inline="always")
def sense_tick(b, tick, state, arena, task, ew):
    """Episode b's inputs for tick `tick`: rays (cast again only for robots that moved, unless robots see each
    other, whose rays depend on the others too), then the encoding with its noise."""
    pose, raw, obs, _, rflag, _, _ = state
    walls, boxes, dirs, _, _ = arena
    params, seed, keys = task
    trig, at, others, cand = ew
    see = params[P_SEE] > 0.5
    for r in range(pose.shape[1]):
        x = pose[b, r, X]
        y = pose[b, r, Y]
        h = pose[b, r, H]
        if see or not (x == at[r, 1] and y == at[r, 2] and h == at[r, 3] and x != 0.0 and y != 0.0 and h != 0.0):
            heading_trig(r, h, trig, at)
            cast_robot_rays(b, r, trig[r, 0], trig[r, 1], pose, raw, walls, boxes, dirs, params, others, cand)
            at[r, 1] = x
            at[r, 2] = y
            at[r, 3] = h
    encode_episode(b, tick, raw, obs, rflag, params, seed, keys[b])


@njit(cache=True, error_model="numpy", inline="always")
def finish_tick(b, tick, state, arena, task, ew, sense):
    """End episode b's tick after motion: the fitness sample (and automatic signal), then, with `sense`, the
    inputs of the next tick."""
    pose, _, _, racc, rflag, goto, est = state
    _, _, _, pois, home = arena
    score_tick(b, tick, pose, racc, rflag, goto, est, pois, home, task[0])
    if sense:
        sense_tick(b, tick + 1, state, arena, task, ew)


@njit(cache=True, error_model="numpy", inline="always")
def play_tick(b, actions, state, arena, task, ew, sense):
    """One tick of episode b with the actions actions[b, r] decided: decide, move, score, sense.

    Decisions first, then motion: a robot's decision reads only its own inputs, rays and pose, and its noise
    draws are pure functions of (seed, episode, tick, robot, channel), so the order is free.  Returns the tick.
    """
    tick = decide_tick(b, actions, state, task)
    move_tick(b, state, arena, task, ew)
    finish_tick(b, tick, state, arena, task, ew, sense)
    return tick


@njit(cache=True, error_model="numpy", inline="always")
def reward_tick(b, state, arena, scores):
    """The team fitness if episode b ended now, its change since the last tick, and `solved`."""
    pose, _, _, racc, rflag, goto, est = state
    prev_fit, rewards, solved = scores
    fit, ok = team_fitness(b, pose, racc, rflag, goto, est, arena[4])
    rewards[b] = fit - prev_fit[b]
    prev_fit[b] = fit
    solved[b] = ok


@njit(cache=True, error_model="numpy", inline="always")
def random_actions(b, tick, actions, p_left, p_forward, task):
    """The random team's action source: each robot of episode b draws left, forward or right into actions[b]."""
    _, seed, keys = task
    for r in range(actions.shape[1]):
        u = uniform(seed, keys[b], tick, r, CH_ACTION)
        actions[b, r] = 0 if u < p_left else (1 if u < p_left + p_forward else 2)


@njit(cache=True, error_model="numpy", inline="always")
def network_actions(b, actions, state, nets, brains):
    """The controllers' action source: each robot of episode b asks its network (`remembered_action`, which
    skips exact repeats) into actions[b].  Networks of the substrate's size run packed, every node in a lane
    of one vector (`remembered_action_16`)."""
    obs = state[2]
    rflag = state[4]
    wt_ih, wt_hh, wt_ho, b_h, b_o, hid, out, brain = nets
    wpack, bpack, lanes, tmp_h, prev, memo_obs, memo = brains
    for r in range(actions.shape[1]):
        if is_size_9(wt_ih):
            actions[b, r] = remembered_action_16(b, r, obs, rflag[b, r, F_SIGNAL], wt_ih.shape[2], wpack, bpack,
                                                 lanes, brain, prev, memo_obs, memo)
        else:
            actions[b, r] = remembered_action(b, r, obs, rflag[b, r, F_SIGNAL], wt_ih, wt_hh, wt_ho, b_h, b_o, hid,
                                              out, brain, tmp_h, prev, memo_obs, memo)


@njit(cache=True, error_model="numpy", inline="always")
def record_tick(b, tick, actions, pose, traj):
    """traj[b, tick, r] = (x, y, heading, action) of every robot of episode b."""
    for r in range(pose.shape[1]):
        traj[b, tick, r, 0] = pose[b, r, X]
        traj[b, tick, r, 1] = pose[b, r, Y]
        traj[b, tick, r, 2] = pose[b, r, H]
        traj[b, tick, r, 3] = actions[b, r]


# ------------------------------------------------------------------ whole episodes (one call per episode)
# The parallel loops below hand each episode to one of these plain compiled functions instead of inlining
# the tick into the parallel loop's body: numba 0.68's parallel loops lose writes into arrays that reach an
# inlined function inside a tuple (its dead-code removal does not see them alias the arguments).  One call
# per episode costs nothing; inside it the tick is inlined as everywhere else.

@njit(cache=True, error_model="numpy")
def controller_episode(b, actions, state, arena, task, ew, nets, brains, traj, record):
    """Episode b from its reset state to the end with the networks deciding; its team fitness and `solved`.

    `brains` (wpack, bpack, lanes, tmp_h, prev, memo_obs, memo) holds the packed networks and their state
    (run_controllers) and this episode's network scratch and memos.
    """
    pose = state[0]
    hid, out = nets[5], nets[6]
    lanes = brains[2]
    n_ticks = int(task[0][P_MAXT])
    size_9 = is_size_9(nets[0])
    if size_9:
        for r in range(pose.shape[1]):
            for i in range(9):
                lanes[b, r, i] = hid[b, r, i]
            for q in range(3):
                lanes[b, r, OUT_LANE + q] = out[b, r, q]
    if record:
        record_tick(b, 0, actions, pose, traj)  # actions[b] = -1 here: no action before the first tick
    for t in range(1, n_ticks + 1):
        network_actions(b, actions, state, nets, brains)
        tick = play_tick(b, actions, state, arena, task, ew, t < n_ticks)
        if record:
            record_tick(b, tick, actions, pose, traj)
    if size_9:
        for r in range(pose.shape[1]):
            for i in range(9):
                hid[b, r, i] = lanes[b, r, i]
            for q in range(3):
                out[b, r, q] = lanes[b, r, OUT_LANE + q]
    return team_fitness(b, pose, state[3], state[4], state[5], state[6], arena[4])


@njit(cache=True, error_model="numpy")
def random_episode(b, actions, state, arena, task, ew, p_left, p_forward):
    """Episode b from its reset state to the end with a random team; its team fitness and `solved`."""
    n_ticks = int(task[0][P_MAXT])
    for t in range(1, n_ticks + 1):
        random_actions(b, t, actions, p_left, p_forward, task)
        play_tick(b, actions, state, arena, task, ew, t < n_ticks)
    pose = state[0]
    return team_fitness(b, pose, state[3], state[4], state[5], state[6], arena[4])


# ------------------------------------------------------------------ loops over the episodes
@njit(cache=True, error_model="numpy")
def forget_rays(work):
    """Clear the memos (after raw was written or the robots were placed anew): the next sensing casts every ray."""
    trig, at, _, _ = work
    at[:] = np.nan
    trig[:] = 0.0


@njit(cache=True, error_model="numpy")
def sense_all(tick, state, arena, task, work):
    """Every episode's inputs for tick `tick` (after a reset, or robots placed by hand)."""
    for b in range(state[0].shape[0]):
        sense_tick(b, tick, state, arena, task, episode_work(work, b))


@njit(cache=True, error_model="numpy")
def decide_all(actions, state, task):
    """Start a tick in every episode: advance the clock and turn actions into heading and velocity."""
    for b in range(state[0].shape[0]):
        decide_tick(b, actions, state, task)


@njit(cache=True, error_model="numpy")
def finish_all(state, arena, task, work, scores):
    """End a tick in every episode after motion: fitness sample, sensing for the next tick, and the reward."""
    est = state[6]
    for b in range(est.shape[0]):
        finish_tick(b, est[b, E_TICK], state, arena, task, episode_work(work, b), True)
        reward_tick(b, state, arena, scores)


@njit(cache=True, error_model="numpy")
def step_all(actions, state, arena, task, work, scores):
    """One tick of every episode with given actions (B, R) (the env and RL vector-env path)."""
    for b in range(actions.shape[0]):
        play_tick(b, actions, state, arena, task, episode_work(work, b), True)
        reward_tick(b, state, arena, scores)


# In the parallel loops, arrays are taken out of their tuples one by one (never `a, b = t`: numba 0.68's
# parallel loops then lose the writes into them) and scratch is allocated before the loop, not in its body:
# arrays from outside the parallel loop reach its body without a reference count (numba passes them as plain
# pointers), so the reference counting of the functions they go to is a null test instead of an atomic update.

@njit(cache=True, error_model="numpy", parallel=True)
def run_controllers(state, arena, task, work, nets, result, traj, record):
    """Whole episodes with the controllers in the loop, episodes spread over the cores.

    State arrays must hold the reset state (poses placed, first sensing done).  With `record`, traj[b, t]
    receives (x, y, heading, action) of every robot after tick t (t = 0 is the start).
    """
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
    trig = work[0]
    at = work[1]
    others = work[2]
    cand = work[3]
    wt_ih = nets[0]
    wt_hh = nets[1]
    wt_ho = nets[2]
    b_h = nets[3]
    b_o = nets[4]
    hid = nets[5]
    out = nets[6]
    brain = nets[7]
    fitness = result[0]
    solved = result[1]
    n_ep = pose.shape[0]
    n_robots = pose.shape[1]
    n_hidden = wt_hh.shape[3]
    actions = np.full((n_ep, n_robots), -1, dtype=np.int64)
    tmp_all = np.empty((n_ep, n_hidden + 3), dtype=np.float32)
    prev_all = np.empty((n_ep, n_hidden), dtype=np.float32)
    memo_obs_all = np.empty((n_ep, n_robots, wt_ih.shape[3]), dtype=np.float32)
    memo_all = np.zeros((n_ep, n_robots, 3), dtype=np.int64)
    # Networks of the substrate's size run packed (`pack_networks`), hidden nodes and outputs in `lanes`.
    if is_size_9(wt_ih):
        wpack = np.empty(wt_ih.shape[:3] + (LANES, LANES), dtype=np.float32)
        bpack = np.empty(wt_ih.shape[:3] + (LANES,), dtype=np.float32)
        pack_networks(wt_ih, wt_hh, wt_ho, b_h, b_o, wpack, bpack)
    else:
        wpack = np.zeros((1, 1, 1, LANES, LANES), dtype=np.float32)
        bpack = np.zeros((1, 1, 1, LANES), dtype=np.float32)
    lanes = np.zeros((n_ep, n_robots, LANES), dtype=np.float32)
    for b in prange(n_ep):
        fit, ok = controller_episode(
            b, actions, (pose, raw, obs, racc, rflag, goto, est), (walls, boxes, dirs, pois, home),
            (params, seed, keys), (trig[b], at[b], others[b], cand[b]),
            (wt_ih, wt_hh, wt_ho, b_h, b_o, hid, out, brain),
            (wpack, bpack, lanes, tmp_all[b], prev_all[b], memo_obs_all[b], memo_all[b]), traj, record)
        fitness[b] = fit
        solved[b] = ok


@njit(cache=True, error_model="numpy", parallel=True)
def run_random(state, arena, task, work, p_left, p_forward, result):
    """Whole episodes of a random team (each robot draws left/forward/right every tick), on all cores.

    The random-policy reference for baselines, and the core's raw-throughput benchmark.
    """
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
    trig = work[0]
    at = work[1]
    others = work[2]
    cand = work[3]
    fitness = result[0]
    solved = result[1]
    actions = np.zeros((pose.shape[0], pose.shape[1]), dtype=np.int64)
    for b in prange(pose.shape[0]):
        fit, ok = random_episode(b, actions, (pose, raw, obs, racc, rflag, goto, est),
                                 (walls, boxes, dirs, pois, home), (params, seed, keys),
                                 (trig[b], at[b], others[b], cand[b]), p_left, p_forward)
        fitness[b] = fit
        solved[b] = ok
