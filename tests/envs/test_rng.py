"""The core's counter-based draws: a pure function of (seed, episode, tick, robot, channel), equal to an
independent Python reference, and the same whether taken whole (`uniform`) or from a per-tick key."""
from __future__ import annotations

import itertools

import numpy as np
from numba import njit

from mahn_envs.core.rng import MAX_SEED, stream_uniform, tick_stream, uniform

MASK = 2**64 - 1


def _mix_ref(z: int) -> int:
    z = ((z ^ (z >> 30)) * 0xBF58476D1CE4E5B9) & MASK
    z = ((z ^ (z >> 27)) * 0x94D049BB133111EB) & MASK
    return z ^ (z >> 31)


def uniform_ref(seed: int, episode: int, tick: int, robot: int, channel: int) -> float:
    """splitmix64's finaliser over the key, written from its definition with Python integers."""
    z = _mix_ref((seed + 0x9E3779B97F4A7C15) & MASK)
    z = _mix_ref(z ^ ((episode * 0x9E3779B97F4A7C15) & MASK))
    z = _mix_ref(z ^ ((tick * 0xBF58476D1CE4E5B9) & MASK))
    z = _mix_ref(z ^ (((robot * 64 + channel) * 0x94D049BB133111EB) & MASK))
    return (z >> 11) / 2.0**53


@njit(cache=True)
def _draws(seed, episode, tick, n_robots, n_channels):
    whole = np.empty((n_robots, n_channels))
    keyed = np.empty((n_robots, n_channels))
    stream = tick_stream(seed, episode, tick)
    for r in range(n_robots):
        for c in range(n_channels):
            whole[r, c] = uniform(seed, episode, tick, r, c)
            keyed[r, c] = stream_uniform(stream, r, c)
    return whole, keyed


def test_draws_match_the_reference_and_the_per_tick_key() -> None:
    for seed, episode, tick in itertools.product((0, 1, 12345, MAX_SEED), (0, 7, 2**40), (1, 690, 1364)):
        whole, keyed = _draws(np.uint64(seed), np.uint64(episode), tick, 3, 17)
        ref = np.array([[uniform_ref(seed, episode, tick, r, c) for c in range(17)] for r in range(3)])
        np.testing.assert_array_equal(whole, ref)
        np.testing.assert_array_equal(keyed, ref)
        assert ((ref >= 0.0) & (ref < 1.0)).all()
        assert len(np.unique(ref)) == ref.size  # every (robot, channel) its own draw


def test_neighbouring_ticks_and_episodes_draw_differently() -> None:
    a, _ = _draws(np.uint64(5), np.uint64(3), 10, 3, 12)
    b, _ = _draws(np.uint64(5), np.uint64(3), 11, 3, 12)
    c, _ = _draws(np.uint64(5), np.uint64(4), 10, 3, 12)
    assert not np.isin(a, b).any() and not np.isin(a, c).any()
    # roughly uniform: the mean of many draws is near 1/2
    many = np.concatenate([_draws(np.uint64(9), np.uint64(e), t, 3, 12)[0].ravel()
                           for e in range(20) for t in range(1, 30)])
    assert abs(many.mean() - 0.5) < 0.01
