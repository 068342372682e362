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
    Networks of the substrate's size (7 inputs, 9 hidden) run in `network_action_9`, which gives the same
    results faster; other sizes run the general loops here.
    """
    if is_size_9(wt_ih):
        return network_action_9(b, r, obs, rflag_signal, wt_ih, wt_hh, wt_ho, b_h, b_o, hid, out, brain, tmp)
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


@njit(cache=True, error_model="numpy", inline="always")
def is_size_9(wt_ih):
    """True for networks of the substrate's size (7 inputs, 9 hidden nodes): `network_action_9` applies."""
    return wt_ih.shape[3] == 7 and wt_ih.shape[4] == 9


@njit(cache=True, error_model="numpy")
def network_action_9(b, r, obs, rflag_signal, wt_ih, wt_hh, wt_ho, b_h, b_o, hid, out, brain, tmp):
    """`network_action` for 7 inputs and 9 hidden nodes (see `is_size_9`): the same float32 operations in the
    same order, so bit-identical results, in about 30 % less time.

    Node by node, each sum runs over its sources in order with the running sum in a register; the inputs and
    the hidden state are read into locals once per step.  (The general loops keep 9 sums in the scratch
    array, which the compiler must store and reload around every multiply-add: it cannot prove the float32
    arrays distinct.)  The first step's outputs are not computed: the second step overwrites them before
    anything reads them (outputs feed nothing back).  No branch on the network size in here: with one,
    numba no longer removes the reference counting of the array arguments (calls on every network step).
    """
    wanted = 1 if (wt_ih.shape[2] == 2 and rflag_signal != 0) else 0
    if wanted != brain[b, r]:  # switch brains (a cleared signal, in operator protocols, switches back)
        brain[b, r] = wanted
        for i in range(9):
            hid[b, r, i] = 0.0
        for o in range(3):
            out[b, r, o] = 0.0
    k = brain[b, r]
    # inputs and state in locals: loaded once, not once per node (the stores to tmp might alias them)
    x0 = obs[b, r, 0]
    x1 = obs[b, r, 1]
    x2 = obs[b, r, 2]
    x3 = obs[b, r, 3]
    x4 = obs[b, r, 4]
    x5 = obs[b, r, 5]
    x6 = obs[b, r, 6]
    h0 = hid[b, r, 0]
    h1 = hid[b, r, 1]
    h2 = hid[b, r, 2]
    h3 = hid[b, r, 3]
    h4 = hid[b, r, 4]
    h5 = hid[b, r, 5]
    h6 = hid[b, r, 6]
    h7 = hid[b, r, 7]
    h8 = hid[b, r, 8]
    # step 1: hidden nodes only
    for i in range(9):
        acc = np.float32(0.0)
        acc += wt_ih[b, r, k, 0, i] * x0
        acc += wt_ih[b, r, k, 1, i] * x1
        acc += wt_ih[b, r, k, 2, i] * x2
        acc += wt_ih[b, r, k, 3, i] * x3
        acc += wt_ih[b, r, k, 4, i] * x4
        acc += wt_ih[b, r, k, 5, i] * x5
        acc += wt_ih[b, r, k, 6, i] * x6
        acc += wt_hh[b, r, k, 0, i] * h0
        acc += wt_hh[b, r, k, 1, i] * h1
        acc += wt_hh[b, r, k, 2, i] * h2
        acc += wt_hh[b, r, k, 3, i] * h3
        acc += wt_hh[b, r, k, 4, i] * h4
        acc += wt_hh[b, r, k, 5, i] * h5
        acc += wt_hh[b, r, k, 6, i] * h6
        acc += wt_hh[b, r, k, 7, i] * h7
        acc += wt_hh[b, r, k, 8, i] * h8
        tmp[i] = acc
    for i in range(9):
        hid[b, r, i] = _sigmoid(tmp[i] + b_h[b, r, k, i])
    # step 2: outputs (from the hidden state of step 1), then hidden nodes
    h0 = hid[b, r, 0]
    h1 = hid[b, r, 1]
    h2 = hid[b, r, 2]
    h3 = hid[b, r, 3]
    h4 = hid[b, r, 4]
    h5 = hid[b, r, 5]
    h6 = hid[b, r, 6]
    h7 = hid[b, r, 7]
    h8 = hid[b, r, 8]
    for q in range(3):
        acc = np.float32(0.0)
        acc += wt_ho[b, r, k, 0, q] * h0
        acc += wt_ho[b, r, k, 1, q] * h1
        acc += wt_ho[b, r, k, 2, q] * h2
        acc += wt_ho[b, r, k, 3, q] * h3
        acc += wt_ho[b, r, k, 4, q] * h4
        acc += wt_ho[b, r, k, 5, q] * h5
        acc += wt_ho[b, r, k, 6, q] * h6
        acc += wt_ho[b, r, k, 7, q] * h7
        acc += wt_ho[b, r, k, 8, q] * h8
        tmp[9 + q] = acc
    for i in range(9):
        acc = np.float32(0.0)
        acc += wt_ih[b, r, k, 0, i] * x0
        acc += wt_ih[b, r, k, 1, i] * x1
        acc += wt_ih[b, r, k, 2, i] * x2
        acc += wt_ih[b, r, k, 3, i] * x3
        acc += wt_ih[b, r, k, 4, i] * x4
        acc += wt_ih[b, r, k, 5, i] * x5
        acc += wt_ih[b, r, k, 6, i] * x6
        acc += wt_hh[b, r, k, 0, i] * h0
        acc += wt_hh[b, r, k, 1, i] * h1
        acc += wt_hh[b, r, k, 2, i] * h2
        acc += wt_hh[b, r, k, 3, i] * h3
        acc += wt_hh[b, r, k, 4, i] * h4
        acc += wt_hh[b, r, k, 5, i] * h5
        acc += wt_hh[b, r, k, 6, i] * h6
        acc += wt_hh[b, r, k, 7, i] * h7
        acc += wt_hh[b, r, k, 8, i] * h8
        tmp[i] = acc
    for i in range(9):
        hid[b, r, i] = _sigmoid(tmp[i] + b_h[b, r, k, i])
    for q in range(3):
        out[b, r, q] = _sigmoid(tmp[9 + q] + b_o[b, r, k, q])
    return winner_take_all(out[b, r, 0], out[b, r, 1], out[b, r, 2])
