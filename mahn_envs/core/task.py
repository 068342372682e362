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

from ..khepera import IR_CALIBRATION_A, IR_CALIBRATION_B, IR_CALIBRATION_C, IR_NOISE_GAP_M, IR_NOISE_SIGMA, IR_RAW_MAX
from .geometry import cast_rays_trig, touches_any_wall
from .rng import CH_HEADING, CH_SENSOR, CH_SENSOR_GAUSS, CH_SPEED, CH_TURN, stream_uniform, tick_stream

# indices into the float64 parameter vector built by TaskParams.vector()
P_RADIUS, P_SPEED, P_TURN, P_DT, P_IR, P_RANGE, P_FLOOR = 0, 1, 2, 3, 4, 5, 6
P_SNOISE, P_ENOISE, P_HNOISE, P_MAXT, P_PERIOD, P_SIGT, P_SEE, P_AUTOSIG, P_REFLEX = 7, 8, 9, 10, 11, 12, 13, 14, 15
P_CEIL, P_RNOISE, P_SMODEL = 16, 17, 18
N_PARAMS = 19

#: how a ray becomes a sensor value (TaskParams.sensor_model): "uniform", the original's gap / IR range plus
#: +-sensor_noise/100 uniform noise; "khepera", a real Khepera III IR sensor as the emulator makes one (a 12-bit
#: count by the paper's calibration, Gaussian noise of sensor_noise/100 times a real sensor's relative noise at
#: that gap, rounded to a count, and calibrated back): `khepera_unit`
SENSOR_MODELS = ("uniform", "khepera")

# pose / racc / rflag / est columns
X, Y, H, V = 0, 1, 2, 3
R_END, R_ORIG_DIST, R_ORIG_HEAD, R_COLL = 0, 1, 2, 3
F_SIGNAL, F_TURNED, F_REACH = 0, 1, 2
E_TICK, E_ALLCLOSE, E_SWITCHED = 0, 1, 2
#: every robot's bit set: the robot mask (bit r: robot r) of an episode whose robots all play (robot episodes:
#: kernels.run_controllers)
ALL_ROBOTS = -1

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


# reflex responses (`reflex_response`): which side is blocked decides how a forward action is changed
REFLEX_CLEAR, REFLEX_LEFT_BLOCKED, REFLEX_FRONT_BLOCKED, REFLEX_RIGHT_BLOCKED = 0, 1, 2, 3


@njit(cache=True, error_model="numpy", inline="always")
def unit_reading(d, f_radius, f_ir):
    """A ray's centre-to-hit distance as the un-floored sensor value (d - radius) / IR range, in float32
    (1 = free at the IR range, 0 = touching).  The inputs and the reflex both start from it."""
    return (np.float32(d) - f_radius) / f_ir


@njit(cache=True, error_model="numpy", inline="always")
def input_value(s, f_floor, f_ceil):
    """The network input of a float32 sensor value: capped at 1, 1 at or above the ceiling, and 0 at or below
    the floor (0.25).  The ceiling (TaskParams.input_ceiling) is 1 in the original, where it changes nothing;
    below 1 it reads a nearly open ray as open, so sensor noise cannot move the input of open space."""
    if s >= f_ceil:
        s = np.float32(1.0)
    if s <= f_floor:
        s = np.float32(0.0)
    return s


#: log10 of the largest count, and ln 10: the calibration runs on natural exponentials and logarithms (cheaper than
#: powers of ten in the compiled loop; within 1e-15 of the emulator's numpy formulas)
_LOG10_RAW_MAX = math.log10(IR_RAW_MAX)
_LN10 = math.log(10.0)
_GAP_M = tuple(float(x) for x in IR_NOISE_GAP_M)
_SIGMA = tuple(float(x) for x in IR_NOISE_SIGMA)


@njit(cache=True, error_model="numpy", inline="always")
def ir_relative_noise(gap):
    """A real IR sensor's relative noise (sigma / count) at `gap` cm: IR_NOISE_SIGMA interpolated, clamped."""
    x = max(gap, 0.0) / 100.0
    if x >= _GAP_M[-1]:
        return _SIGMA[-1]
    i = 0
    while x > _GAP_M[i + 1]:
        i += 1
    return _SIGMA[i] + (_SIGMA[i + 1] - _SIGMA[i]) * (x - _GAP_M[i]) / (_GAP_M[i + 1] - _GAP_M[i])


@njit(cache=True, error_model="numpy", inline="always")
def khepera_count_sigma(gap, ir_range, noise):
    """A Khepera III sensor `gap` cm from a wall: its noise-free count (`khepera_count`) and its relative noise
    (`ir_relative_noise`; 0 when the noise is off, so a noise-free reading never looks the table up)."""
    return khepera_count(gap, ir_range), ir_relative_noise(gap) if noise > 0.0 else 0.0


@njit(cache=True, error_model="numpy", inline="always")
def khepera_count(gap, ir_range):
    """The noise-free 12-bit count (not yet rounded) of a Khepera III IR sensor `gap` cm from a wall, by the
    paper's calibration."""
    log_count = min(IR_CALIBRATION_B + (IR_CALIBRATION_A - gap / ir_range) * IR_CALIBRATION_C, _LOG10_RAW_MAX)
    return math.exp(log_count * _LN10)


@njit(cache=True, error_model="numpy")
def unit_of_count(count):
    """A rounded count calibrated back to the simulator's scale, clipped to [0, 1]."""
    u = IR_CALIBRATION_A - (math.log(count) / _LN10 - IR_CALIBRATION_B) / IR_CALIBRATION_C
    return min(max(u, 0.0), 1.0)


#: unit_of_count of every count 0..IR_RAW_MAX (index 0 unused: a count is at least 1), made by the compiled function
#: itself, so a lookup gives the bits the formula gives in the kernels, without a logarithm per ray
UNIT_OF_COUNT = np.array([unit_of_count(float(max(k, 1))) for k in range(IR_RAW_MAX + 1)])


@njit(cache=True, error_model="numpy", inline="always")
def khepera_reading(count, sigma, noise, g):
    """The noise-free `count` times 1 + noise x sigma x g (g a standard Gaussian draw, sigma the relative noise at
    the ray's gap), rounded to a count in [1, IR_RAW_MAX] (below one count nothing is reflected: reads free) and
    calibrated back (UNIT_OF_COUNT)."""
    if noise > 0.0:
        count = count * (1.0 + noise * sigma * g)
    count = np.rint(count)
    if count > float(IR_RAW_MAX):
        count = float(IR_RAW_MAX)
    if not count >= 1.0:  # also a NaN: never an index outside the table
        count = 1.0
    return UNIT_OF_COUNT[int(count)]


@njit(cache=True, error_model="numpy", inline="always")
def khepera_unit(gap, ir_range, noise, g):
    """A Khepera III IR reading of a wall `gap` cm from the sensor, on the simulator's scale: the paper's
    calibration turned into a 12-bit count, times 1 + noise x sigma(gap) x g (g a standard Gaussian draw; sigma a
    real sensor's relative noise, `ir_relative_noise`), rounded to a count and calibrated back, clipped to [0, 1]:
    what the emulator (hardware.emulated_world) answers and the hardware env reads, in float64."""
    count, sigma = khepera_count_sigma(gap, ir_range, noise)
    return khepera_reading(count, sigma, noise, g)


@njit(cache=True, error_model="numpy", inline="always")
def sensed_reading(b, r, j, raw, params, noise, stream):
    """Sensor j of robot r as the original's uniform sensor model senses it for the tick of `stream`
    (`rng.tick_stream`): the unit reading with +-noise uniform (the draw of (r, sensor j)), before the cap and the
    floor, in float32."""
    s = unit_reading(raw[b, r, j], np.float32(params[P_RADIUS]), np.float32(params[P_IR]))
    if noise > 0.0:
        s = np.float32(s + np.float32(noise * (2.0 * stream_uniform(stream, r, CH_SENSOR + j) - 1.0)))
    return s


@njit(cache=True, error_model="numpy", inline="always")
def khepera_ray(b, r, j, raw, params, noise, free_count, free_sigma):
    """The noise-free count and relative noise of robot r's ray j: those of a free ray (`free_count`,
    `free_sigma`, computed once per tick) when it hit nothing, the most common case, else from its gap."""
    if raw[b, r, j] == params[P_RANGE]:
        return free_count, free_sigma
    return khepera_count_sigma(raw[b, r, j] - params[P_RADIUS], params[P_IR], noise)


@njit(cache=True, error_model="numpy", inline="always")
def sensor_gaussian_pair(stream, r, j):
    """The standard Gaussians of robot r's sensors j and j + 1 for the tick of `stream` (the "khepera" model): one
    Box-Muller pair from the draws of sensor j and CH_SENSOR_GAUSS + j."""
    radius = math.sqrt(-2.0 * math.log(1.0 - stream_uniform(stream, r, CH_SENSOR + j)))
    angle = 2.0 * math.pi * stream_uniform(stream, r, CH_SENSOR_GAUSS + j)
    return radius * math.cos(angle), radius * math.sin(angle)


#: no table of sensor Gaussians (`encode_episode`'s gauss with row -1): every pair is computed where it is read
NO_GAUSSIANS = np.zeros((0, 0, 0, 0))


@njit(cache=True, error_model="numpy", inline="always")
def khepera_pair(b, r, j, tick, raw, params, noise, stream, free_count, free_sigma, gauss, row):
    """Sensors j and j + 1 of robot r by the "khepera" model for tick `tick` (of `stream`), in float32, from one
    pair of Gaussians (`sensor_gaussian_pair`): read from gauss[row, tick, r] when the episode has a row there (its
    key's pairs computed once for every episode of that key, kernels.fill_sensor_gaussians), else computed."""
    g0 = 0.0
    g1 = 0.0
    if noise > 0.0:
        if row >= 0 and tick < gauss.shape[1]:
            g0 = gauss[row, tick, r, j]
            g1 = gauss[row, tick, r, j + 1]
        else:
            g0, g1 = sensor_gaussian_pair(stream, r, j)
    count0, sigma0 = khepera_ray(b, r, j, raw, params, noise, free_count, free_sigma)
    count1, sigma1 = khepera_ray(b, r, j + 1, raw, params, noise, free_count, free_sigma)
    return (np.float32(khepera_reading(count0, sigma0, noise, g0)),
            np.float32(khepera_reading(count1, sigma1, noise, g1)))


@njit(cache=True, error_model="numpy", inline="always")
def encode_episode(b, tick, raw, obs, rflag, params, seed, key):
    """Turn ray distances into inputs: (d - 6.5)/10.16 in float32, noise, capped at 1, floored to 0 at <= 0.25."""
    encode_episode_with(b, tick, raw, obs, rflag, params, seed, key, NO_GAUSSIANS, -1)


@njit(cache=True, error_model="numpy", inline="always")
def encode_episode_with(b, tick, raw, obs, rflag, params, seed, key, gauss, row, robots=ALL_ROBOTS):
    """`encode_episode` with the "khepera" model's Gaussians read from gauss[row] where row >= 0 (see
    `khepera_pair`): the same inputs, bit for bit.  Only the robots whose bit is set in `robots` (default: all)
    are encoded (robot episodes, kernels.run_controllers)."""
    f_floor = np.float32(params[P_FLOOR])
    f_ceil = np.float32(params[P_CEIL])
    noise = params[P_SNOISE] / 100.0
    khepera = params[P_SMODEL] > 0.5
    stream = tick_stream(seed, key, tick)  # every draw of this tick starts from it
    free_count = 0.0
    free_sigma = 0.0
    if khepera:  # a ray that hit nothing reads the range's gap
        free_count, free_sigma = khepera_count_sigma(params[P_RANGE] - params[P_RADIUS], params[P_IR], noise)
    for r in range(raw.shape[1]):
        if not (robots >> r) & 1:
            continue
        if khepera:
            for j in range(0, 6, 2):
                s0, s1 = khepera_pair(b, r, j, tick, raw, params, noise, stream, free_count, free_sigma, gauss, row)
                obs[b, r, j] = input_value(s0, f_floor, f_ceil)
                obs[b, r, j + 1] = input_value(s1, f_floor, f_ceil)
        else:
            for j in range(6):
                obs[b, r, j] = input_value(sensed_reading(b, r, j, raw, params, noise, stream), f_floor,
                                           f_ceil)
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
def reflex_response(q0, q1, q2, q3, q4, q5, f_floor):
    """The collision-avoidance reflex: which of the six float32 sensor values (index 0 leftmost) are at or below
    the floor, checked left pair, then front pair, then right pair (the first blocked side wins)."""
    if q0 <= f_floor or q1 <= f_floor:
        return REFLEX_LEFT_BLOCKED
    if q2 <= f_floor or q3 <= f_floor:
        return REFLEX_FRONT_BLOCKED
    if q4 <= f_floor or q5 <= f_floor:
        return REFLEX_RIGHT_BLOCKED
    return REFLEX_CLEAR


@njit(cache=True, error_model="numpy", inline="always")
def steer(action, response, velocity, speed, arc=False):
    """An action and the reflex's response -> (turn, velocity): turn +1 left, -1 right, 0 none, by one step.

    Forward: blocked left -> turn right, velocity unchanged; blocked ahead -> stand still without turning;
    blocked right -> turn left, velocity unchanged; clear -> drive at `speed`.  Left and right turn in place.
    "Velocity unchanged" is the original's quirk: a driving robot arcs round the obstacle, a standing one turns
    in place.  With `arc` (TaskParams.reflex_arc) the side branches drive at `speed` instead, so a standing robot
    arcs too.
    """
    if arc:
        velocity = speed
    if action == FORWARD:
        if response == REFLEX_LEFT_BLOCKED:
            return -1, velocity
        if response == REFLEX_FRONT_BLOCKED:
            return 0, 0.0
        if response == REFLEX_RIGHT_BLOCKED:
            return 1, velocity
        return 0, speed
    if action == LEFT:
        return 1, 0.0
    if action == RIGHT:
        return -1, 0.0
    return 0, 0.0


@njit(cache=True, error_model="numpy", inline="always")
def decide_robot(b, r, action, tick, pose, raw, obs, params, seed, key):
    """Apply an action (and, for forward, the collision-avoidance reflex) to heading and velocity.

    In our y-up frame a left turn increases the heading.  Reflex branches a and c keep the previous velocity
    and the front branch stops without turning: original quirks that shape the evolved behaviour (`steer`).
    Returns True when the front reflex blocked the robot (the original's `corrected`).
    """
    return decide_robot_drawn(b, r, action, pose, raw, obs, params, tick_stream(seed, key, tick))


@njit(cache=True, error_model="numpy", inline="always")
def decide_robot_drawn(b, r, action, pose, raw, obs, params, stream):
    """`decide_robot` for the tick of `stream` (`rng.tick_stream`, computed once per tick by the hot loops)."""
    speed = params[P_SPEED]
    turn = params[P_TURN]
    e = params[P_ENOISE] / 100.0
    if e > 0.0:
        speed = speed * (1.0 + e * (2.0 * stream_uniform(stream, r, CH_SPEED) - 1.0))
        turn = turn * (1.0 + e * (2.0 * stream_uniform(stream, r, CH_TURN) - 1.0))
    step = float(np.float32(np.float32(params[P_DT]) * np.float32(turn)))
    response = REFLEX_CLEAR
    if action == FORWARD and params[P_REFLEX] > 0.5:
        if params[P_RNOISE] > 0.5:
            # what the network saw this tick (obs), as a real robot's reflex reads its sensors: a value is at or
            # below the floor exactly when its input is 0 (the encoding floors it to 0 and leaves the others above)
            response = reflex_response(obs[b, r, 0], obs[b, r, 1], obs[b, r, 2], obs[b, r, 3], obs[b, r, 4],
                                       obs[b, r, 5], np.float32(params[P_FLOOR]))
        else:  # the original's simulated reflex: the noise-free rays
            f_radius = np.float32(params[P_RADIUS])
            f_ir = np.float32(params[P_IR])
            response = reflex_response(unit_reading(raw[b, r, 0], f_radius, f_ir),
                                       unit_reading(raw[b, r, 1], f_radius, f_ir),
                                       unit_reading(raw[b, r, 2], f_radius, f_ir),
                                       unit_reading(raw[b, r, 3], f_radius, f_ir),
                                       unit_reading(raw[b, r, 4], f_radius, f_ir),
                                       unit_reading(raw[b, r, 5], f_radius, f_ir),
                                       np.float32(params[P_FLOOR]))
    direction, velocity = steer(action, response, pose[b, r, V], speed, params[P_REFLEX] > 1.5)
    pose[b, r, V] = velocity
    if direction > 0:
        pose[b, r, H] += step
    elif direction < 0:
        pose[b, r, H] -= step
    hn = params[P_HNOISE]
    if hn > 0.0:
        pose[b, r, H] += hn * (2.0 * stream_uniform(stream, r, CH_HEADING) - 1.0)
    return response == REFLEX_FRONT_BLOCKED


@njit(cache=True, error_model="numpy", inline="always")
def move_robot(b, r, pose, racc, params, walls, boxes):
    """Drive straight for one tick; on touching a wall go back to where the tick started (no sliding)."""
    return drive_robot(b, r, math.cos(pose[b, r, H]), math.sin(pose[b, r, H]), pose, racc, params, walls, boxes)


@njit(cache=True, error_model="numpy", inline="always")
def drive_robot(b, r, ch, sh, pose, racc, params, walls, boxes):
    """`move_robot` given ch, sh = cos and sin of the heading (shared with sensing in the episode loop)."""
    d = pose[b, r, V] * params[P_DT]
    return settle_robot(b, r, pose[b, r, X] + ch * d, pose[b, r, Y] + sh * d, pose, racc, params, walls, boxes)


@njit(cache=True, error_model="numpy", inline="always")
def wall_revert(ox, oy, nx, ny, radius, walls, boxes):
    """Where a move from (ox, oy) to (nx, ny) ends: there, or back at its start when the robot would touch a
    wall (the original's rule: no sliding along walls).  Returns (x, y, touched)."""
    if touches_any_wall(nx, ny, radius, walls, boxes):
        return ox, oy, True
    return nx, ny, False


@njit(cache=True, error_model="numpy", inline="always")
def settle_robot(b, r, nx, ny, pose, racc, params, walls, boxes):
    """Move robot r to (nx, ny) under the wall rule (`wall_revert`), counting a collision when it is reverted.
    Returns True when the robot moved."""
    x, y, touched = wall_revert(pose[b, r, X], pose[b, r, Y], nx, ny, params[P_RADIUS], walls, boxes)
    if touched:
        racc[b, r, R_COLL] += 1.0
        return False
    pose[b, r, X] = x
    pose[b, r, Y] = y
    return True


@njit(cache=True, error_model="numpy", inline="always")
def _manhattan(x, y, px, py):
    return abs(x - px) + abs(y - py)


@njit(cache=True, error_model="numpy", inline="always")
def give_signal(b, pose, racc, rflag, est, pois, home):
    """The come-home event: remember where everyone is and whether every POI is covered."""
    n_robots = pose.shape[1]
    signal_team(b, rflag, est)
    for i in range(n_robots):
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


@njit(cache=True, error_model="numpy", inline="always")
def signal_team(b, rflag, est):
    """Give every robot the come-home signal and mark the episode as switched (no later automatic signal)."""
    for i in range(rflag.shape[1]):
        rflag[b, i, F_SIGNAL] = 1
    est[b, E_SWITCHED] = 1


@njit(cache=True, error_model="numpy", inline="always")
def signal_due(b, tick, est, params):
    """The automatic come-home signal: at `signal_tick` (a sample tick), unless the episode was switched."""
    return params[P_AUTOSIG] > 0.5 and tick == int(params[P_SIGT]) and est[b, E_SWITCHED] == 0


@njit(cache=True, error_model="numpy", inline="always")
def score_tick(b, tick, pose, racc, rflag, goto, est, pois, home, params):
    """Fitness bookkeeping after motion; samples every `period` ticks, the signal at `signal_tick`."""
    period = int(params[P_PERIOD])
    if tick % period != 0:
        return
    if signal_due(b, tick, est, params):
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
