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


def transposed(controllers) -> tuple:
    """(wt_ih, wt_hh, wt_ho, b_h, b_o) of a batch: weights as contiguous [source, target] for the kernel."""
    c = controllers.as_batch()
    return (np.ascontiguousarray(np.swapaxes(c.w_ih, -1, -2)), np.ascontiguousarray(np.swapaxes(c.w_hh, -1, -2)),
            np.ascontiguousarray(np.swapaxes(c.w_ho, -1, -2)), c.b_h, c.b_o)


@njit(cache=True, error_model="numpy")
def network_action(b, r, obs, rflag_signal, wt_ih, wt_hh, wt_ho, b_h, b_o, hid, out, brain, tmp):
    """Two synchronous network steps on this tick's inputs, then winner-take-all.

    Weights come transposed ([source, target], see `transposed`) so the inner loops run over contiguous
    targets.  Situational teams switch to brain 1 with zeroed state on the first tick they see the signal.
    State (`hid`, `out`, `brain`: (B, R, ...)) persists across ticks; `tmp` is float32 scratch of n_hidden + 3.
    """
    n_brains = wt_ih.shape[2]
    n_hidden = wt_hh.shape[3]
    n_in = wt_ih.shape[3]
    wanted = 1 if (n_brains == 2 and rflag_signal != 0) else 0
    if wanted != brain[b, r]:  # switch brains (a cleared signal, in operator protocols, switches back)
        brain[b, r] = wanted
        for i in range(n_hidden):
            hid[b, r, i] = 0.0
        for o in range(3):
            out[b, r, o] = 0.0
    k = brain[b, r]
    # Full indexing, no sub-array views: a view costs a reference-count round trip per call in numba.
    # Accumulators for all targets advance together, source by source: every node still sums its inputs in
    # the original order (bit-identical float32), but the independent sums pipeline and vectorise.
    for _ in range(2):
        for q in range(3):
            tmp[n_hidden + q] = np.float32(0.0)
        for m in range(n_hidden):
            hm = hid[b, r, m]
            for q in range(3):
                tmp[n_hidden + q] += wt_ho[b, r, k, m, q] * hm
        for i in range(n_hidden):
            tmp[i] = np.float32(0.0)
        for j in range(n_in):
            xj = obs[b, r, j]
            for i in range(n_hidden):
                tmp[i] += wt_ih[b, r, k, j, i] * xj
        for m in range(n_hidden):
            hm = hid[b, r, m]
            for i in range(n_hidden):
                tmp[i] += wt_hh[b, r, k, m, i] * hm
        # outputs read the hidden state of the previous step
        for q in range(3):
            out[b, r, q] = _sigmoid(tmp[n_hidden + q] + b_o[b, r, k, q])
        for i in range(n_hidden):
            hid[b, r, i] = _sigmoid(tmp[i] + b_h[b, r, k, i])
    return winner_take_all(out[b, r, 0], out[b, r, 1], out[b, r, 2])
