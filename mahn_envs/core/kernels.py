"""Compiled batch loops over episodes.  Thin: every rule lives in core.task and core.controller."""
from __future__ import annotations

import numpy as np
from numba import njit, prange

from .controller import is_size_9, network_action, network_action_9
from .rng import CH_ACTION, uniform
from .task import (E_TICK, F_SIGNAL, H, P_MAXT, X, Y, decide_robot, move_robot, score_tick,
                   sense_episode, team_fitness)


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
    size_9 = is_size_9(wt_ih)
    # Scratch allocated here, not in the loop body: arrays from outside the parallel loop reach its body
    # without a reference count (numba passes them as plain pointers), so the per-call reference counting of
    # the functions they go to is a null test instead of an atomic update.
    others_all = np.empty((n_ep, n_robots, 2), dtype=np.float64)
    cand_all = np.empty((n_ep, walls.shape[0]), dtype=np.int64)
    tmp_all = np.empty((n_ep, wt_hh.shape[3] + 3), dtype=np.float32)
    for b in prange(n_ep):
        others = others_all[b]
        cand = cand_all[b]
        tmp_h = tmp_all[b]
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
                    action = network_action_9(b, r, obs, rflag[b, r, F_SIGNAL], wt_ih, wt_hh, wt_ho, b_h, b_o,
                                              hid, out, brain, tmp_h)
                else:
                    action = network_action(b, r, obs, rflag[b, r, F_SIGNAL], wt_ih, wt_hh, wt_ho, b_h, b_o,
                                            hid, out, brain, tmp_h)
                decide_robot(b, r, action, tick, pose, raw, params, seed, keys[b])
                if record:
                    traj[b, tick, r, 3] = action
            for r in range(n_robots):
                move_robot(b, r, pose, racc, params, walls, boxes)
            score_tick(b, tick, pose, racc, rflag, goto, est, pois, home, params)
            if record:
                for r in range(n_robots):
                    traj[b, tick, r, 0] = pose[b, r, X]
                    traj[b, tick, r, 1] = pose[b, r, Y]
                    traj[b, tick, r, 2] = pose[b, r, H]
            if tick < n_ticks:
                sense_episode(b, tick + 1, pose, raw, obs, rflag, walls, boxes, dirs, params, seed, keys[b],
                              others, cand)
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
