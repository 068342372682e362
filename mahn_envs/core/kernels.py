"""Compiled batch loops over episodes.  Thin: every rule lives in core.task and core.controller.

Numba caches these loops keyed on this file only: after changing a rule in task.py, geometry.py or
controller.py, change this file too (even a comment), or the cache keeps running the old compiled rules.
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
    move_robot,
    score_tick,
    sense_episode,
    team_fitness,
)


@njit(cache=True, error_model="numpy")
def sense_all(tick, pose, raw, obs, rflag, walls, boxes, dirs, params, seed, keys, others, cand):
    for b in range(pose.shape[0]):
        sense_episode(b, tick, pose, raw, obs, rflag, walls, boxes, dirs, params, seed, keys[b], others, cand)


@njit(cache=True, error_model="numpy")
def decide_all(actions, pose, raw, est, params, seed, keys):
    """Start a tick in every episode: advance the clock and turn actions into heading and velocity."""
    for b in range(pose.shape[0]):
        tick = est[b, E_TICK] + 1
        est[b, E_TICK] = tick
        for r in range(pose.shape[1]):
            decide_robot(b, r, actions[b, r], tick, pose, raw, params, seed, keys[b])


@njit(cache=True, error_model="numpy")
def move_all(pose, racc, params, walls, boxes):
    for b in range(pose.shape[0]):
        for r in range(pose.shape[1]):
            move_robot(b, r, pose, racc, params, walls, boxes)


@njit(cache=True, error_model="numpy")
def finish_all(pose, raw, obs, racc, rflag, goto, est, prev_fit, rewards, solved, walls, boxes, dirs,
               pois, home, params, seed, keys, others, cand):
    """End a tick: fitness sample, sensing for the next tick, and the reward (change of team fitness)."""
    for b in range(pose.shape[0]):
        tick = est[b, E_TICK]
        score_tick(b, tick, pose, racc, rflag, goto, est, pois, home, params)
        sense_episode(b, tick + 1, pose, raw, obs, rflag, walls, boxes, dirs, params, seed, keys[b], others, cand)
        fit, ok = team_fitness(b, pose, racc, rflag, goto, est, home)
        rewards[b] = fit - prev_fit[b]
        prev_fit[b] = fit
        solved[b] = ok


@njit(cache=True, error_model="numpy")
def step_all(actions, pose, raw, obs, racc, rflag, goto, est, prev_fit, rewards, solved, walls, boxes, dirs,
             pois, home, params, seed, keys, others, cand):
    """One tick of every episode with given actions (the env and RL vector-env path)."""
    decide_all(actions, pose, raw, est, params, seed, keys)
    move_all(pose, racc, params, walls, boxes)
    finish_all(pose, raw, obs, racc, rflag, goto, est, prev_fit, rewards, solved, walls, boxes, dirs,
               pois, home, params, seed, keys, others, cand)


@njit(cache=True, error_model="numpy", parallel=True)
def run_controllers(pose, raw, obs, racc, rflag, goto, est, walls, boxes, dirs, pois, home, params, seed, keys,
                    wt_ih, wt_hh, wt_ho, b_h, b_o, hid, out, brain, fitness, solved, traj, record):
    """Whole episodes with the controllers in the loop, episodes spread over the cores.

    State arrays must hold the reset state (poses placed, first sensing done).  With `record`, traj[b, t]
    receives (x, y, heading, action) of every robot after tick t (t = 0 is the start).
    """
    n_ep = pose.shape[0]
    n_robots = pose.shape[1]
    n_ticks = int(params[P_MAXT])
    n_hidden = wt_hh.shape[3]
    see = params[P_SEE] > 0.5
    # Scratch allocated here, not in the loop body: arrays from outside the parallel loop reach its body
    # without a reference count (numba passes them as plain pointers), so the per-call reference counting of
    # the functions they go to is a null test instead of an atomic update.
    others_all = np.empty((n_ep, n_robots, 2), dtype=np.float64)
    cand_all = np.empty((n_ep, walls.shape[0]), dtype=np.int64)
    tmp_all = np.empty((n_ep, n_hidden + 3), dtype=np.float32)
    prev_all = np.empty((n_ep, n_hidden), dtype=np.float32)
    memo_obs_all = np.empty((n_ep, n_robots, wt_ih.shape[3]), dtype=np.float32)
    memo_all = np.zeros((n_ep, n_robots, 3), dtype=np.int64)
    # per robot: cos, sin of the heading `at[r, 0]`; rays cast from (at[r, 1], at[r, 2]) with heading at[r, 3]
    trig_all = np.empty((n_ep, n_robots, 2), dtype=np.float64)
    at_all = np.full((n_ep, n_robots, 4), np.nan)
    # Networks of the substrate's size run packed, every node in a lane of one vector (`_network_16`), their
    # hidden nodes and outputs in `state`, copied from and back to `hid` and `out`.
    size_9 = is_size_9(wt_ih)
    n_brains = wt_ih.shape[2]
    if size_9:
        wpack = np.empty(wt_ih.shape[:3] + (LANES, LANES), dtype=np.float32)
        bpack = np.empty(wt_ih.shape[:3] + (LANES,), dtype=np.float32)
        pack_networks(wt_ih, wt_hh, wt_ho, b_h, b_o, wpack, bpack)
    else:
        wpack = np.zeros((1, 1, 1, LANES, LANES), dtype=np.float32)
        bpack = np.zeros((1, 1, 1, LANES), dtype=np.float32)
    state = np.zeros((n_ep, n_robots, LANES), dtype=np.float32)
    for b in prange(n_ep):
        others = others_all[b]
        cand = cand_all[b]
        tmp_h = tmp_all[b]
        prev = prev_all[b]
        memo_obs = memo_obs_all[b]
        memo = memo_all[b]
        trig = trig_all[b]
        at = at_all[b]
        if size_9:
            for r in range(n_robots):
                for i in range(9):
                    state[b, r, i] = hid[b, r, i]
                for q in range(3):
                    state[b, r, OUT_LANE + q] = out[b, r, q]
        if record:
            for r in range(n_robots):
                traj[b, 0, r, 0] = pose[b, r, X]
                traj[b, 0, r, 1] = pose[b, r, Y]
                traj[b, 0, r, 2] = pose[b, r, H]
                traj[b, 0, r, 3] = -1.0
        for tick in range(1, n_ticks + 1):
            est[b, E_TICK] = tick
            for r in range(n_robots):
                # Numba's cache keys on this file's text only: after changing a called function (e.g. the
                # network), change this file too, or cached episodes keep running the old compiled code.
                # The task's functions are inlined here (inline="always"): as calls, each one paid a reference
                # count round trip per array argument, which cost more than half of the episode's time.
                if size_9:
                    action = remembered_action_16(b, r, obs, rflag[b, r, F_SIGNAL], n_brains, wpack, bpack, state,
                                                  brain, prev, memo_obs, memo)
                else:
                    action = remembered_action(b, r, obs, rflag[b, r, F_SIGNAL], wt_ih, wt_hh, wt_ho, b_h, b_o,
                                               hid, out, brain, tmp_h, prev, memo_obs, memo)
                decide_robot(b, r, action, tick, pose, raw, params, seed, keys[b])
                if record:
                    traj[b, tick, r, 3] = action
            # Motion and sensing share one cos and sin of each heading (sensing sees the heading of the move),
            # kept while the heading stays the same; rays are cast again only when a robot has moved (or others
            # can be seen).  Pure functions of the same arguments: the results are the same numbers.  Zero is
            # never taken as unchanged (sin(-0.0) is -0.0), nor NaN (never equal).
            for r in range(n_robots):
                h = pose[b, r, H]
                if not (h == at[r, 0] and h != 0.0):
                    trig[r, 0] = math.cos(h)
                    trig[r, 1] = math.sin(h)
                    at[r, 0] = h
                drive_robot(b, r, trig[r, 0], trig[r, 1], pose, racc, params, walls, boxes)
            score_tick(b, tick, pose, racc, rflag, goto, est, pois, home, params)
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
                    if see or not (x == at[r, 1] and y == at[r, 2] and h == at[r, 3] and x != 0.0 and y != 0.0
                                   and h != 0.0):
                        cast_robot_rays(b, r, trig[r, 0], trig[r, 1], pose, raw, walls, boxes, dirs, params, others,
                                        cand)
                        at[r, 1] = x
                        at[r, 2] = y
                        at[r, 3] = h
                encode_episode(b, tick + 1, raw, obs, rflag, params, seed, keys[b])
        if size_9:
            for r in range(n_robots):
                for i in range(9):
                    hid[b, r, i] = state[b, r, i]
                for q in range(3):
                    out[b, r, q] = state[b, r, OUT_LANE + q]
        fit, ok = team_fitness(b, pose, racc, rflag, goto, est, home)
        fitness[b] = fit
        solved[b] = ok


@njit(cache=True, error_model="numpy", parallel=True)
def run_random(pose, raw, obs, racc, rflag, goto, est, walls, boxes, dirs, pois, home, params, seed, keys,
               p_left, p_forward, fitness, solved):
    """Whole episodes of a random team (each robot draws left/forward/right every tick), on all cores.

    The random-policy reference for baselines, and the core's raw-throughput benchmark.
    """
    n_ep = pose.shape[0]
    n_robots = pose.shape[1]
    n_ticks = int(params[P_MAXT])
    for b in prange(n_ep):
        others = np.empty((n_robots, 2), dtype=np.float64)
        cand = np.empty(walls.shape[0], dtype=np.int64)
        for tick in range(1, n_ticks + 1):
            est[b, E_TICK] = tick
            for r in range(n_robots):
                u = uniform(seed, keys[b], tick, r, CH_ACTION)
                action = 0 if u < p_left else (1 if u < p_left + p_forward else 2)
                decide_robot(b, r, action, tick, pose, raw, params, seed, keys[b])
                move_robot(b, r, pose, racc, params, walls, boxes)
            score_tick(b, tick, pose, racc, rflag, goto, est, pois, home, params)
            if tick < n_ticks:
                sense_episode(b, tick + 1, pose, raw, obs, rflag, walls, boxes, dirs, params, seed, keys[b],
                              others, cand)
        fit, ok = team_fitness(b, pose, racc, rflag, goto, est, home)
        fitness[b] = fit
        solved[b] = ok
