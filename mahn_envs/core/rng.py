"""Counter-based random numbers for the compiled core.

Every random draw is a pure function of (seed, episode, tick, robot, channel).  Unlike a stateful generator this
gives the same numbers whichever thread runs an episode and whatever order the episodes run in, so a batch
evaluated on two cores equals the same batch evaluated on one, and one episode equals itself inside any batch.
"""
from __future__ import annotations

import numpy as np
from numba import njit

_GOLDEN = np.uint64(0x9E3779B97F4A7C15)
_M1 = np.uint64(0xBF58476D1CE4E5B9)
_M2 = np.uint64(0x94D049BB133111EB)
_S30 = np.uint64(30)
_S27 = np.uint64(27)
_S31 = np.uint64(31)
_S11 = np.uint64(11)
_INV53 = 1.0 / 9007199254740992.0

#: seeds are unsigned 64-bit integers: the compiled core mixes them as uint64
MAX_SEED = 2**64 - 1


def check_seed(seed: object, field: str = "seed") -> int:
    """A seed as a Python int in [0, 2**64); anything else (negative, a float or string, a bool, wider than 64
    bits, where numba would overflow) is a TypeError/ValueError naming `field`."""
    if isinstance(seed, (bool, np.bool_)) or not isinstance(seed, (int, np.integer)):
        raise TypeError(f"{field} must be an integer in [0, 2**64), got {seed!r} of type {type(seed).__name__}")
    if not 0 <= int(seed) <= MAX_SEED:
        raise ValueError(f"{field} must be an integer in [0, 2**64), got {seed!r}")
    return int(seed)


# channels: one per kind of draw, so draws never collide
CH_SENSOR = 0  # + sensor index (0..5)
CH_SPEED = 8
CH_TURN = 9
CH_HEADING = 10
CH_ACTION = 11
CH_SENSOR_GAUSS = 16  # + sensor index: the second uniform of a sensor's Gaussian draw (sensor_model 'khepera')


@njit(cache=True, error_model="numpy", inline="always")
def _mix(z):
    z = (z ^ (z >> _S30)) * _M1
    z = (z ^ (z >> _S27)) * _M2
    return z ^ (z >> _S31)


@njit(cache=True, error_model="numpy", inline="always")
def tick_stream(seed, episode, tick):
    """The key every draw of one episode's tick starts from: the first three of `uniform`'s four mixes, computed
    once per tick by the hot loops (one mix per draw instead of four; the numbers are the same)."""
    z = _mix(np.uint64(seed) + _GOLDEN)
    z = _mix(z ^ (np.uint64(episode) * _GOLDEN))
    return _mix(z ^ (np.uint64(tick) * _M1))


@njit(cache=True, error_model="numpy", inline="always")
def stream_uniform(stream, robot, channel):
    """`uniform(seed, episode, tick, robot, channel)` given stream = tick_stream(seed, episode, tick)."""
    z = _mix(stream ^ (np.uint64(robot * 64 + channel) * _M2))
    return float(z >> _S11) * _INV53


@njit(cache=True, error_model="numpy", inline="always")
def uniform(seed, episode, tick, robot, channel):
    """A float in [0, 1) determined by its coordinates (splitmix64 finaliser over a combined key)."""
    return stream_uniform(tick_stream(seed, episode, tick), robot, channel)
