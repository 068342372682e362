"""The patrol-and-return task, written once: sensing, the reflex, motion, walls, the signal and the fitness.

Each function works on one episode `b` of batch-shaped state arrays, so the same code runs inside the
trainer's fused parallel loop, the env's per-step kernel and the pymunk engine.  Numbers and their quirks
(float32 rounding points, the /10 and /100 rules, Manhattan vs Euclidean) follow
docs/original-system.md sections 2-4 and 7.

State layout (B episodes, R robots, P points of interest):
  pose  (B, R, 4) float64  x, y, heading, velocity
  raw   (B, R, 6) float64  last centre-to-hit ray distances
  obs   (B, R, 7) float32  six IR inputs then the come-home signal
  racc  (B, R, 4) float64  return credit, distance to home at the signal, heading at the signal, collisions
  rflag (B, R, 3) uint8    signal, turned since the signal, reached home
  goto  (B, P)    float64  patrol credit per point of interest
  est   (B, 3)    int64    tick, all POIs covered at the signal, signal given
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

from .geometry import cast_rays_trig, touches_any_wall
from .rng import CH_HEADING, CH_SENSOR, CH_SPEED, CH_TURN, uniform

# indices into the float64 parameter vector built by TaskParams.vector()
P_RADIUS, P_SPEED, P_TURN, P_DT, P_IR, P_RANGE, P_FLOOR = 0, 1, 2, 3, 4, 5, 6
P_SNOISE, P_ENOISE, P_HNOISE, P_MAXT, P_PERIOD, P_SIGT, P_SEE, P_AUTOSIG, P_REFLEX = 7, 8, 9, 10, 11, 12, 13, 14, 15
N_PARAMS = 16

# pose / racc / rflag / est columns
X, Y, H, V = 0, 1, 2, 3
R_END, R_ORIG_DIST, R_ORIG_HEAD, R_COLL = 0, 1, 2, 3
F_SIGNAL, F_TURNED, F_REACH = 0, 1, 2
E_TICK, E_ALLCLOSE, E_SWITCHED = 0, 1, 2

# actions: the substrate's output order, plus an internal "no decision" for NaN outputs
LEFT, FORWARD, RIGHT, NONE = 0, 1, 2, 3

# fitness constants of POIFIT_MO
POI_REACHED = 10.0
POI_SCALE = 110.0
POI_CLOSE = 15.0
HOME_REACHED = 20.0
RETURN_SCALE = 167.0
MOVED_MIN = 5.0
SOLVED_BONUS = 100.0


@njit(cache=True, error_model="numpy", inline="always")
def encode_episode(b, tick, raw, obs, rflag, params, seed, key):
    """Turn ray distances into inputs: (d - 6.5)/10.16 in float32, noise, capped at 1, floored to 0 at <= 0.25."""
    f_radius = np.float32(params[P_RADIUS])
    f_ir = np.float32(params[P_IR])
    f_floor = np.float32(params[P_FLOOR])
    noise = params[P_SNOISE] / 100.0
    for r in range(raw.shape[1]):
        for j in range(6):
            s = (np.float32(raw[b, r, j]) - f_radius) / f_ir
            if noise > 0.0:
                s = np.float32(s + np.float32(noise * (2.0 * uniform(seed, key, tick, r, CH_SENSOR + j) - 1.0)))
            if s > np.float32(1.0):
                s = np.float32(1.0)
            if s <= f_floor:
                s = np.float32(0.0)
            obs[b, r, j] = s
        obs[b, r, 6] = np.float32(rflag[b, r, F_SIGNAL])


@njit(cache=True, error_model="numpy", inline="always")
def sense_episode(b, tick, pose, raw, obs, rflag, walls, boxes, dirs, params, seed, key, others, cand):
    """Cast every robot's rays and encode them as the inputs of the coming tick.

    `others` (R, 2) and `cand` (W,) are scratch arrays, passed in so the hot loop never allocates.
    """
    for r in range(pose.shape[1]):
        cast_robot_rays(b, r, math.cos(pose[b, r, H]), math.sin(pose[b, r, H]), pose, raw, walls, boxes, dirs,
                        params, others, cand)
    encode_episode(b, tick, raw, obs, rflag, params, seed, key)


@njit(cache=True, error_model="numpy", inline="always")
def cast_robot_rays(b, r, ch, sh, pose, raw, walls, boxes, dirs, params, others, cand):
    """Robot r's ray distances into raw[b, r], given ch, sh = cos and sin of its heading."""
    n_others = 0
    if params[P_SEE] > 0.5:
        for q in range(pose.shape[1]):
            if q != r:
                others[n_others, 0] = pose[b, q, X]
                others[n_others, 1] = pose[b, q, Y]
                n_others += 1
    cast_rays_trig(pose[b, r, X], pose[b, r, Y], ch, sh, dirs, params[P_RANGE], walls, boxes, others, n_others,
                   params[P_RADIUS], raw[b, r], cand)


@njit(cache=True, error_model="numpy", inline="always")
def decide_robot(b, r, action, tick, pose, raw, params, seed, key):
    """Apply an action (and, for forward, the collision-avoidance reflex) to heading and velocity.

    In our y-up frame a left turn increases the heading.  Reflex branches a and c keep the previous velocity
    and the front branch stops without turning: original quirks that shape the evolved behaviour.
    Returns True when the front reflex blocked the robot (the original's `corrected`).
    """
    speed = params[P_SPEED]
    turn = params[P_TURN]
    e = params[P_ENOISE] / 100.0
    if e > 0.0:
        speed = speed * (1.0 + e * (2.0 * uniform(seed, key, tick, r, CH_SPEED) - 1.0))
        turn = turn * (1.0 + e * (2.0 * uniform(seed, key, tick, r, CH_TURN) - 1.0))
    step = float(np.float32(np.float32(params[P_DT]) * np.float32(turn)))
    corrected = False
    if action == FORWARD:
        f_radius = np.float32(params[P_RADIUS])
        f_ir = np.float32(params[P_IR])
        f_floor = np.float32(params[P_FLOOR])
        q0 = (np.float32(raw[b, r, 0]) - f_radius) / f_ir
        q1 = (np.float32(raw[b, r, 1]) - f_radius) / f_ir
        q2 = (np.float32(raw[b, r, 2]) - f_radius) / f_ir
        q3 = (np.float32(raw[b, r, 3]) - f_radius) / f_ir
        q4 = (np.float32(raw[b, r, 4]) - f_radius) / f_ir
        q5 = (np.float32(raw[b, r, 5]) - f_radius) / f_ir
        if params[P_REFLEX] > 0.5 and (q0 <= f_floor or q1 <= f_floor):
            pose[b, r, H] -= step  # wall on the left: turn right, velocity unchanged
        elif params[P_REFLEX] > 0.5 and (q2 <= f_floor or q3 <= f_floor):
            pose[b, r, V] = 0.0  # wall ahead: stand still
            corrected = True
        elif params[P_REFLEX] > 0.5 and (q4 <= f_floor or q5 <= f_floor):
            pose[b, r, H] += step  # wall on the right: turn left, velocity unchanged
        else:
            pose[b, r, V] = speed
    elif action == LEFT:
        pose[b, r, V] = 0.0
        pose[b, r, H] += step
    elif action == RIGHT:
        pose[b, r, V] = 0.0
        pose[b, r, H] -= step
    else:
        pose[b, r, V] = 0.0
    hn = params[P_HNOISE]
    if hn > 0.0:
        pose[b, r, H] += hn * (2.0 * uniform(seed, key, tick, r, CH_HEADING) - 1.0)
    return corrected


@njit(cache=True, error_model="numpy", inline="always")
def move_robot(b, r, pose, racc, params, walls, boxes):
    """Drive straight for one tick; on touching a wall go back to where the tick started (no sliding)."""
    return drive_robot(b, r, math.cos(pose[b, r, H]), math.sin(pose[b, r, H]), pose, racc, params, walls, boxes)


@njit(cache=True, error_model="numpy", inline="always")
def drive_robot(b, r, ch, sh, pose, racc, params, walls, boxes):
    """`move_robot` given ch, sh = cos and sin of the heading (shared with sensing in the episode loop)."""
    ox = pose[b, r, X]
    oy = pose[b, r, Y]
    d = pose[b, r, V] * params[P_DT]
    nx = ox + ch * d
    ny = oy + sh * d
    if touches_any_wall(nx, ny, params[P_RADIUS], walls, boxes):
        racc[b, r, R_COLL] += 1.0
        return False
    pose[b, r, X] = nx
    pose[b, r, Y] = ny
    return True


@njit(cache=True, error_model="numpy", inline="always")
def _manhattan(x, y, px, py):
    return abs(x - px) + abs(y - py)


@njit(cache=True, error_model="numpy", inline="always")
def give_signal(b, pose, racc, rflag, est, pois, home):
    """The come-home event: remember where everyone is and whether every POI is covered."""
    n_robots = pose.shape[1]
    for i in range(n_robots):
        rflag[b, i, F_SIGNAL] = 1
        racc[b, i, R_ORIG_DIST] = math.hypot(pose[b, i, X] - home[0], pose[b, i, Y] - home[1])
        racc[b, i, R_ORIG_HEAD] = pose[b, i, H]
    all_close = 1
    for p in range(pois.shape[0]):
        covered = False
        for i in range(n_robots):
            if _manhattan(pose[b, i, X], pose[b, i, Y], pois[p, 0], pois[p, 1]) < POI_CLOSE:
                covered = True
        if not covered:
            all_close = 0
    est[b, E_ALLCLOSE] = all_close
    est[b, E_SWITCHED] = 1


@njit(cache=True, error_model="numpy", inline="always")
def score_tick(b, tick, pose, racc, rflag, goto, est, pois, home, params):
    """Fitness bookkeeping after motion; samples every `period` ticks, the signal at `signal_tick`."""
    period = int(params[P_PERIOD])
    if tick % period != 0:
        return
    if params[P_AUTOSIG] > 0.5 and tick == int(params[P_SIGT]) and est[b, E_SWITCHED] == 0:
        give_signal(b, pose, racc, rflag, est, pois, home)
    n_robots = pose.shape[1]
    if est[b, E_SWITCHED] == 0:
        for p in range(pois.shape[0]):
            g = 0.0
            for i in range(n_robots):
                d1 = _manhattan(pose[b, i, X], pose[b, i, Y], pois[p, 0], pois[p, 1])
                v = 1.0 if d1 <= POI_REACHED else max(0.0, (POI_SCALE - d1) / POI_SCALE)
                if v > g:
                    g = v
            goto[b, p] += g
    else:
        for i in range(n_robots):
            d2 = _manhattan(pose[b, i, X], pose[b, i, Y], home[0], home[1])
            if pose[b, i, H] != racc[b, i, R_ORIG_HEAD]:
                rflag[b, i, F_TURNED] = 1
            if d2 <= HOME_REACHED:
                rflag[b, i, F_REACH] = 1
            racc[b, i, R_END] += max(0.0, (racc[b, i, R_ORIG_DIST] - d2) / RETURN_SCALE)


@njit(cache=True, error_model="numpy", inline="always")
def team_fitness(b, pose, racc, rflag, goto, est, home):
    """The score if the episode ended now: 1e-6 + patrol + return credit, the penalties, +100 if solved."""
    n_robots = pose.shape[1]
    all_close = est[b, E_ALLCLOSE] == 1
    moved = True
    reached = True
    for j in range(n_robots):
        d = _manhattan(pose[b, j, X], pose[b, j, Y], home[0], home[1])
        if not (rflag[b, j, F_TURNED] == 1 or racc[b, j, R_ORIG_DIST] - d >= MOVED_MIN):
            moved = False
        if rflag[b, j, F_REACH] == 0:
            reached = False
    fit = 1e-6
    for p in range(goto.shape[1]):
        fit += goto[b, p] if (all_close and moved) else goto[b, p] / 10.0
    for i in range(n_robots):
        fit += racc[b, i, R_END] if all_close else racc[b, i, R_END] / 100.0
    solved = all_close and moved and reached
    if solved:
        fit += SOLVED_BONUS
    return fit, solved
