"""The evolved controllers inside the compiled loop: substrate networks as plain float32 arrays.

A team's controllers are five arrays with shape (R, K, ...) (a batch adds a leading B):
  w_ih (R, K, 9, 7)  input -> hidden, inputs = six IR values then the come-home signal
  w_hh (R, K, 9, 9)  hidden -> hidden, [target, source], self-loops included
  w_ho (R, K, 3, 9)  hidden -> output (left, forward, right)
  b_h  (R, K, 9)     hidden biases
  b_o  (R, K, 3)     output biases
K is the number of brains per robot: 1 for standard policy geometry (the signal is input 6) and 2 for
situational policy geometry (brain 0 patrols, brain 1 returns and starts from a fresh state at the signal;
column 6 of w_ih is zero).  The same arrays drive the batch core, the PettingZoo env and the real robots.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

from .task import FORWARD, LEFT, NONE, RIGHT

SIGMOID_SLOPE = np.float32(4.9)


@njit(cache=True, error_model="numpy", inline="always")
def _sigmoid(x):
    return np.float32(1.0) / (np.float32(1.0) + np.float32(math.exp(-SIGMOID_SLOPE * x)))


@njit(cache=True, error_model="numpy")
def winner_take_all(o0, o1, o2):
    """Forward wins every tie, then left beats right; NaN outputs decide nothing (the original's rule)."""
    if o1 - o0 >= 0 and o1 - o2 >= 0:
        return FORWARD
    if o0 - o1 >= 0 and o0 - o2 >= 0:
        return LEFT
    if o2 - o0 >= 0 and o2 - o1 >= 0:
        return RIGHT
    return NONE


@njit(cache=True, error_model="numpy")
def network_action(b, r, obs, rflag_signal, w_ih, w_hh, w_ho, b_h, b_o, hid, out, brain, tmp_h):
    """Two synchronous network steps on this tick's inputs, then winner-take-all.

    Situational teams switch to brain 1 with zeroed state on the first tick they see the signal.
    State (`hid`, `out`, `brain`: (B, R, ...)) persists across ticks.
    """
    n_brains = w_ih.shape[2]
    n_hidden = w_hh.shape[3]
    n_in = w_ih.shape[4]
    if n_brains == 2 and rflag_signal != 0 and brain[b, r] == 0:
        brain[b, r] = 1
        for i in range(n_hidden):
            hid[b, r, i] = 0.0
        for o in range(3):
            out[b, r, o] = 0.0
    k = brain[b, r]
    for _ in range(2):
        # outputs read the hidden state of the previous step, so compute them first
        for o in range(3):
            acc = np.float32(0.0)
            for m in range(n_hidden):
                acc += w_ho[b, r, k, o, m] * hid[b, r, m]
            out[b, r, o] = _sigmoid(acc + b_o[b, r, k, o])
        for i in range(n_hidden):
            acc = np.float32(0.0)
            for j in range(n_in):
                acc += w_ih[b, r, k, i, j] * obs[b, r, j]
            for m in range(n_hidden):
                acc += w_hh[b, r, k, i, m] * hid[b, r, m]
            tmp_h[i] = _sigmoid(acc + b_h[b, r, k, i])
        for i in range(n_hidden):
            hid[b, r, i] = tmp_h[i]
    return winner_take_all(out[b, r, 0], out[b, r, 1], out[b, r, 2])
