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

import numpy as np
from llvmlite import ir
from numba import njit, types
from numba.extending import intrinsic

from .expf import SIGMOID_SLOPE32, TABLE, expf, sigmoid_8, sigmoid_ir
from .task import ALL_ROBOTS, FORWARD, LEFT, NONE, RIGHT

SIGMOID_SLOPE = SIGMOID_SLOPE32  # 4.9 in float32


@njit(cache=True, error_model="numpy", inline="always")
def _sigmoid(x):
    """1/(1+e^(-4.9x)) in float32; the exponential is the C library's expf, inlined (see core.expf)."""
    return np.float32(1.0) / (np.float32(1.0) + expf(-SIGMOID_SLOPE * x))


#: How a network's three values become an action.  "output": winner-take-all on the outputs, the sigmoids of their
#: net inputs (the original's rule).  In float32 the steep sigmoid saturates to exactly 1.0 (or 0.0) for net inputs
#: beyond about +-3.5 (+-21 at 0.0), so evolved teams often decide by exact ties (forward wins them) that any
#: perturbation reaching an output flips.  "net_input": the same winner-take-all on the net inputs (sum + bias)
#: themselves: the same action whenever the sigmoids differ (the sigmoid is monotone), but a saturated tie goes to
#: the output the network drives hardest, so decisions keep a real margin.
DECISIONS = ("output", "net_input")


@njit(cache=True, error_model="numpy", inline="always")
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
def network_action(b, r, obs, rflag_signal, wt_ih, wt_hh, wt_ho, b_h, b_o, hid, out, brain, tmp, by_net=False):
    """Two synchronous network steps on this tick's inputs, then winner-take-all on the outputs (or, `by_net`, on
    their net inputs: see DECISIONS).

    Weights come transposed ([source, target], see `transposed`) so the inner loops run over contiguous
    targets.  Situational teams switch to brain 1 with zeroed state on the first tick they see the signal.
    State (`hid`, `out`, `brain`: (B, R, ...)) persists across ticks; `tmp` is float32 scratch of n_hidden + 3,
    whose last three hold the outputs' net inputs on return.
    Networks of the substrate's size (7 inputs, 9 hidden) run in `network_action_9`, which gives the same
    results faster; other sizes run the general loops here.
    """
    if is_size_9(wt_ih):
        return network_action_9(b, r, obs, rflag_signal, wt_ih, wt_hh, wt_ho, b_h, b_o, hid, out, brain, tmp,
                                by_net)
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
            tmp[n_hidden + q] = tmp[n_hidden + q] + b_o[b, r, k, q]
            out[b, r, q] = _sigmoid(tmp[n_hidden + q])
        for i in range(n_hidden):
            hid[b, r, i] = _sigmoid(tmp[i] + b_h[b, r, k, i])
    if by_net:
        return winner_take_all(tmp[n_hidden], tmp[n_hidden + 1], tmp[n_hidden + 2])
    return winner_take_all(out[b, r, 0], out[b, r, 1], out[b, r, 2])


def _c_float32(a, ndim: int) -> bool:
    return isinstance(a, types.Array) and a.dtype == types.float32 and a.ndim == ndim and a.layout == "C"


@intrinsic
def _hidden_sums_8(typingctx, dst, wt_ih, ih_at, obs, obs_at, wt_hh, hh_at, hid, hid_at):
    """Sums of hidden nodes 0..7 of a 7-input, 9-hidden network, as one 8-lane vector, into dst[0:8].

    Lane i computes (((0 + wt_ih[ih_at + 9j + i] obs[obs_at + j]) for j = 0..6) + wt_hh[hh_at + 9m + i]
    hid[hid_at + m] for m = 0..8), offsets in elements of the C-contiguous arrays: the scalar loop's
    multiplies and adds, in its order, each rounded to float32 (IEEE vector arithmetic is lane-wise, and
    without fast-math LLVM neither fuses nor reorders them), so the sums are bit-identical.  Written as an
    intrinsic because numba's loop vectoriser gives up on loops this short.
    """
    if not (_c_float32(dst, 1) and _c_float32(wt_ih, 5) and _c_float32(obs, 3) and _c_float32(wt_hh, 5)
            and _c_float32(hid, 3)):
        return None
    sig = types.void(dst, wt_ih, types.intp, obs, types.intp, wt_hh, types.intp, hid, types.intp)

    def codegen(context, builder, signature, args):
        i64 = ir.IntType(64)
        v8 = ir.VectorType(ir.FloatType(), 8)
        p_dst, p_ih, p_obs, p_hh, p_hid = (context.make_array(signature.args[a])(context, builder, args[a]).data
                                           for a in (0, 1, 3, 5, 7))

        def element(ptr, at, k):
            return builder.gep(ptr, [builder.add(at, ir.Constant(i64, k))], inbounds=True)

        def row(ptr, at, k):  # 8 consecutive float32 from element at + k
            return builder.load(builder.bitcast(element(ptr, at, k), v8.as_pointer()), align=4)

        def splat(ptr, at, k):
            v = builder.insert_element(ir.Constant(v8, ir.Undefined), builder.load(element(ptr, at, k)),
                                       ir.Constant(ir.IntType(32), 0))
            return builder.shuffle_vector(v, ir.Constant(v8, ir.Undefined),
                                          ir.Constant(ir.VectorType(ir.IntType(32), 8), [0] * 8))

        ih_at, obs_at, hh_at, hid_at = args[2], args[4], args[6], args[8]
        acc = ir.Constant(v8, [0.0] * 8)
        for j in range(7):
            acc = builder.fadd(acc, builder.fmul(row(p_ih, ih_at, 9 * j), splat(p_obs, obs_at, j)))
        for m in range(9):
            acc = builder.fadd(acc, builder.fmul(row(p_hh, hh_at, 9 * m), splat(p_hid, hid_at, m)))
        builder.store(acc, builder.bitcast(p_dst, v8.as_pointer()), align=4)
        return context.get_dummy_value()

    return sig, codegen


@njit(cache=True, error_model="numpy", inline="always")
def is_size_9(wt_ih):
    """True for networks of the substrate's size (7 inputs, 9 hidden nodes): `network_action_9` applies."""
    return wt_ih.shape[3] == 7 and wt_ih.shape[4] == 9


@njit(cache=True, error_model="numpy", inline="always")
def _hidden_step_9(b, r, k, obs, wt_ih, wt_hh, b_h, hid, tmp, ih_at, hh_at, obs_at, hid_at):
    """One synchronous update of the 9 hidden nodes: nodes 0..7 as one vector, node 8 alone."""
    _hidden_sums_8(tmp, wt_ih, ih_at, obs, obs_at, wt_hh, hh_at, hid, hid_at)
    acc = np.float32(0.0)
    for j in range(7):
        acc += wt_ih[b, r, k, j, 8] * obs[b, r, j]
    for m in range(9):
        acc += wt_hh[b, r, k, m, 8] * hid[b, r, m]
    tmp[8] = acc
    sigmoid_8(hid, hid_at, tmp, 0, b_h, ((b * b_h.shape[1] + r) * b_h.shape[2] + k) * 9, TABLE)
    hid[b, r, 8] = _sigmoid(tmp[8] + b_h[b, r, k, 8])


@njit(cache=True, error_model="numpy", inline="always")
def network_action_9(b, r, obs, rflag_signal, wt_ih, wt_hh, wt_ho, b_h, b_o, hid, out, brain, tmp, by_net=False):
    """`network_action` for 7 inputs and 9 hidden nodes (see `is_size_9`): the same float32 operations in the
    same order, so bit-identical results, in about half the time.

    Hidden nodes 0..7 are summed as one 8-lane vector (`_hidden_sums_8`), node 8 alone, each over its
    sources in the original order.  (The general loops keep the sums in the scratch array, which the compiler
    must store and reload around every multiply-add as it cannot prove the float32 arrays distinct.)  The
    first step's outputs are not computed: the second step overwrites them before anything reads them
    (outputs feed nothing back).  No branch on the network size in here: with one, numba no longer removes
    the reference counting of the array arguments.  Arrays must be C-contiguous, as `transposed` and the
    callers make them.
    """
    wanted = 1 if (wt_ih.shape[2] == 2 and rflag_signal != 0) else 0
    if wanted != brain[b, r]:  # switch brains (a cleared signal, in operator protocols, switches back)
        brain[b, r] = wanted
        for i in range(9):
            hid[b, r, i] = 0.0
        for o in range(3):
            out[b, r, o] = 0.0
    k = brain[b, r]
    # element offsets of this robot's rows (C-contiguous arrays, as `transposed` and the callers make them)
    unit = (b * wt_ih.shape[1] + r) * wt_ih.shape[2] + k
    ih_at = unit * 63
    hh_at = unit * 81
    obs_at = (b * obs.shape[1] + r) * obs.shape[2]
    hid_at = (b * hid.shape[1] + r) * hid.shape[2]
    # step 1: hidden nodes only
    _hidden_step_9(b, r, k, obs, wt_ih, wt_hh, b_h, hid, tmp, ih_at, hh_at, obs_at, hid_at)
    # step 2: outputs (from the hidden state of step 1), then hidden nodes
    for q in range(3):
        acc = np.float32(0.0)
        for m in range(9):
            acc += wt_ho[b, r, k, m, q] * hid[b, r, m]
        tmp[9 + q] = acc
    _hidden_step_9(b, r, k, obs, wt_ih, wt_hh, b_h, hid, tmp, ih_at, hh_at, obs_at, hid_at)
    for q in range(3):
        tmp[9 + q] = tmp[9 + q] + b_o[b, r, k, q]
        out[b, r, q] = _sigmoid(tmp[9 + q])
    if by_net:
        return winner_take_all(tmp[9], tmp[10], tmp[11])
    return winner_take_all(out[b, r, 0], out[b, r, 1], out[b, r, 2])


@njit(cache=True, error_model="numpy", inline="always")
def remembered_action(b, r, obs, rflag_signal, wt_ih, wt_hh, wt_ho, b_h, b_o, hid, out, brain, tmp, prev,
                      memo_obs, memo, by_net=False):
    """`network_action`, skipped when it would repeat itself exactly.

    The network is a pure function of (inputs, signal, hidden state, brain).  When the last call left the
    hidden state where it found it (a fixed point of the two steps, no brain switch) and this call sees the same
    inputs and signal, it would compute the same hidden state, outputs and action again: those are already in
    `hid` and `out`, and the action is remembered.  Evolved robots spend much of an episode in such states (open
    corridors read all-1 inputs).  Per robot, `memo_obs` (R, n_in) float32 holds the inputs of the last call and
    `memo` (R, 3) int64 (fixed point, signal, action), with memo[r, 0] = 0 before the first call; `prev` is
    float32 scratch of n_hidden.  Comparisons are exact (==): inputs and hidden values are never -0.0 (the
    floor and the sigmoid give +0.0), and a NaN never compares equal, so it is always recomputed.
    """
    n_in = wt_ih.shape[3]
    n_hidden = wt_hh.shape[3]
    if memo[r, 0] == 1 and memo[r, 1] == rflag_signal:
        same = True
        for j in range(n_in):
            if obs[b, r, j] != memo_obs[r, j]:
                same = False
        if same:
            return memo[r, 2]
    for i in range(n_hidden):
        prev[i] = hid[b, r, i]
    k = brain[b, r]
    if is_size_9(wt_ih):
        action = network_action_9(b, r, obs, rflag_signal, wt_ih, wt_hh, wt_ho, b_h, b_o, hid, out, brain, tmp,
                                  by_net)
    else:
        action = network_action(b, r, obs, rflag_signal, wt_ih, wt_hh, wt_ho, b_h, b_o, hid, out, brain, tmp,
                                by_net)
    fixed = brain[b, r] == k
    for i in range(n_hidden):
        if hid[b, r, i] != prev[i]:
            fixed = False
    for j in range(n_in):
        memo_obs[r, j] = obs[b, r, j]
    memo[r, 0] = 1 if fixed else 0
    memo[r, 1] = rflag_signal
    memo[r, 2] = action
    return action


#: lanes of a packed network (`pack_networks`): hidden nodes 0..8, outputs 9..11, the outputs' net inputs 12..14
#: (written by `_network_16`, read by nothing but the "net_input" decision), 1 unused
LANES = 16
OUT_LANE = 9
NET_LANE = 12


@njit(cache=True, error_model="numpy")
def pack_networks(wt_ih, wt_hh, wt_ho, b_h, b_o, wpack, bpack):
    """The networks of `transposed` arrays (7 inputs, 9 hidden: `is_size_9`) as rows of 16 lanes for `_network_16`.

    wpack (B, R, K, 16, 16) float32: row j < 7 holds input j's weights to the hidden nodes (lanes 0..8), row
    7 + m hidden node m's weights to the hidden nodes (lanes 0..8) and to the outputs (lanes 9..11); bpack
    (B, R, K, 16) the hidden then output biases.  Unused lanes are 0.
    """
    wpack[:] = 0.0
    bpack[:] = 0.0
    for b in range(wt_ih.shape[0]):
        for r in range(wt_ih.shape[1]):
            for k in range(wt_ih.shape[2]):
                for i in range(9):
                    for j in range(7):
                        wpack[b, r, k, j, i] = wt_ih[b, r, k, j, i]
                    for m in range(9):
                        wpack[b, r, k, 7 + m, i] = wt_hh[b, r, k, m, i]
                    bpack[b, r, k, i] = b_h[b, r, k, i]
                for q in range(3):
                    for m in range(9):
                        wpack[b, r, k, 7 + m, OUT_LANE + q] = wt_ho[b, r, k, m, q]
                    bpack[b, r, k, OUT_LANE + q] = b_o[b, r, k, q]


def _network_16_ir(builder: ir.IRBuilder, p_state, p_w, p_b, p_obs, p_tab, units: list) -> None:
    """IR of `_network_16` for several independent networks at once, their operations interleaved.

    `units` lists each network's element offsets (state_at, w_at, b_at, obs_at).  One network is a chain of
    dependent additions and two sigmoids (about 300 cycles of latency, bit-identity forbids reassociating it);
    the networks of a tick's robots do not depend on each other, so emitting their operations side by side lets
    the core overlap the chains.  Every lane of every unit does the operations of the one-network path in the
    same order: the results are bit-identical."""
    i32, i64 = ir.IntType(32), ir.IntType(64)
    vf = ir.VectorType(ir.FloatType(), LANES)

    def ptr(p, at, k):
        return builder.gep(p, [builder.add(at, ir.Constant(i64, k))], inbounds=True)

    def row(p, at, k):
        return builder.load(builder.bitcast(ptr(p, at, k), vf.as_pointer()), align=4)

    def splat(x):
        v = builder.insert_element(ir.Constant(vf, ir.Undefined), x, ir.Constant(i32, 0))
        return builder.shuffle_vector(v, ir.Constant(vf, ir.Undefined),
                                      ir.Constant(ir.VectorType(i32, LANES), [0] * LANES))

    zero = ir.Constant(vf, [0.0] * LANES)
    hidden_lanes = ir.Constant(ir.VectorType(ir.IntType(1), LANES),
                               [1 if i < OUT_LANE else 0 for i in range(LANES)])
    inputs = [[splat(builder.load(ptr(p_obs, u[3], j))) for j in range(7)] for u in units]
    bias = [row(p_b, u[2], 0) for u in units]
    s = [row(p_state, u[0], 0) for u in units]
    net = list(s)
    for step in range(2):
        acc = [zero] * len(units)
        for j in range(7):
            for n, u in enumerate(units):
                acc[n] = builder.fadd(acc[n], builder.fmul(row(p_w, u[1], LANES * j), inputs[n][j]))
        if step == 1:
            acc = [builder.select(hidden_lanes, a, zero) for a in acc]
        for m in range(9):
            for n, u in enumerate(units):
                hm = splat(builder.extract_element(s[n], ir.Constant(i32, m)))
                acc[n] = builder.fadd(acc[n], builder.fmul(row(p_w, u[1], LANES * (7 + m)), hm))
        net = [builder.fadd(a, bb) for a, bb in zip(acc, bias)]
        s = [sigmoid_ir(builder, x, p_tab) for x in net]
    # lanes NET_LANE.. take the output lanes' net inputs (index LANES + i picks lane i of `net`)
    keep = ir.Constant(ir.VectorType(i32, LANES),
                       list(range(NET_LANE)) + [LANES + OUT_LANE + q for q in range(3)] + [LANES - 1])
    for n, u in enumerate(units):
        out = builder.shuffle_vector(s[n], net[n], keep)
        builder.store(out, builder.bitcast(ptr(p_state, u[0], 0), vf.as_pointer()), align=4)


def _packed_types_ok(state, wpack, bpack, obs, table) -> bool:
    f4 = types.float32
    return (isinstance(state, types.Array) and state.dtype == f4 and state.layout == "C"
            and isinstance(wpack, types.Array) and wpack.dtype == f4 and wpack.layout == "C"
            and isinstance(bpack, types.Array) and bpack.dtype == f4 and bpack.layout == "C"
            and isinstance(obs, types.Array) and obs.dtype == f4 and obs.layout == "C"
            and isinstance(table, types.Array) and table.dtype == types.uint64)


@intrinsic
def _network_16(typingctx, state, state_at, wpack, w_at, bpack, b_at, obs, obs_at, table):
    """Both synchronous steps of a 7-input, 9-hidden network (`network_action_9`) with every node in one lane of a
    16-lane float32 vector: state[state_at:+16] holds hidden nodes 0..8 and outputs (lanes 9..11) before and
    after; wpack, bpack rows from `pack_networks` at element offsets w_at, b_at; inputs obs[obs_at:+7].

    Each lane does its node's operations of `network_action_9` in the same order: from 0, + weight * input for
    the 7 inputs (hidden lanes only: output lanes restart from 0 after them), then + weight * hidden for the 9
    hidden nodes of the previous step, then the sigmoid of sum + bias (`sigmoid_ir`).  IEEE vector arithmetic
    is lane-wise and without fast-math LLVM neither fuses nor reorders it, so every node is bit-identical to
    the scalar network; one vector operation per source replaces the separate hidden, node 8 and output chains.
    Step 1's output lanes are not used (step 2 recomputes the outputs before anything reads them).  Step 2's
    output net inputs (sum + bias, before the sigmoid) are kept in lanes NET_LANE..NET_LANE+2 for the
    "net_input" decision.
    """
    if not _packed_types_ok(state, wpack, bpack, obs, table):
        return None
    sig = types.void(state, types.intp, wpack, types.intp, bpack, types.intp, obs, types.intp, table)

    def codegen(context, builder, signature, args):
        p_state, p_w, p_b, p_obs, p_tab = (context.make_array(signature.args[a])(context, builder, args[a]).data
                                           for a in (0, 2, 4, 6, 8))
        _network_16_ir(builder, p_state, p_w, p_b, p_obs, p_tab, [(args[1], args[3], args[5], args[7])])
        return context.get_dummy_value()

    return sig, codegen


def _networks_16_of(n_units: int):
    """An intrinsic stepping `n_units` packed networks at once (`_network_16_ir`): (state, wpack, bpack, obs,
    table, pending) with pending (>= n_units, PENDING) int64 rows whose first four columns are each network's
    (state_at, w_at, b_at, obs_at)."""

    @intrinsic
    def networks(typingctx, state, wpack, bpack, obs, table, pending):
        if not (_packed_types_ok(state, wpack, bpack, obs, table) and isinstance(pending, types.Array)
                and pending.dtype == types.int64 and pending.ndim == 2 and pending.layout == "C"):
            return None
        sig = types.void(state, wpack, bpack, obs, table, pending)

        def codegen(context, builder, signature, args):
            p_state, p_w, p_b, p_obs, p_tab = (context.make_array(signature.args[a])(context, builder, args[a]).data
                                               for a in range(5))
            p_pend = context.make_array(signature.args[5])(context, builder, args[5]).data
            i64 = ir.IntType(64)
            units = [tuple(builder.load(builder.gep(p_pend, [ir.Constant(i64, n * PENDING + c)], inbounds=True))
                           for c in range(4)) for n in range(n_units)]
            _network_16_ir(builder, p_state, p_w, p_b, p_obs, p_tab, units)
            return context.get_dummy_value()

        return sig, codegen

    return networks


#: columns of a pending network (`remembered_actions_16`): state_at, w_at, b_at, obs_at, robot, brain before
PENDING = 6
_networks_16_2 = _networks_16_of(2)
_networks_16_3 = _networks_16_of(3)


@njit(cache=True, error_model="numpy", inline="always")
def _recall_16(b, r, obs, rflag_signal, n_brains, state, brain, prev, memo_obs, memo):
    """The first half of `remembered_action_16` for robot r: True when the memo holds its action (nothing to
    compute); otherwise the hidden state saved in prev[:9] and the brain switched (a switch clears the state)."""
    if memo[r, 0] == 1 and memo[r, 1] == rflag_signal:
        same = True
        for j in range(7):
            if obs[b, r, j] != memo_obs[r, j]:
                same = False
        if same:
            return True
    for i in range(9):
        prev[i] = state[b, r, i]
    wanted = 1 if (n_brains == 2 and rflag_signal != 0) else 0
    if wanted != brain[b, r]:  # switch brains (a cleared signal, in operator protocols, switches back)
        brain[b, r] = wanted
        for i in range(OUT_LANE + 3):
            state[b, r, i] = 0.0
    return False


@njit(cache=True, error_model="numpy", inline="always")
def _remember_16(b, r, k, obs, rflag_signal, state, brain, prev, memo_obs, memo, by_net):
    """The second half of `remembered_action_16`, after robot r's network stepped from brain k: its action,
    remembered with whether the step left the hidden state (prev[:9]) and brain unchanged."""
    at = NET_LANE if by_net else OUT_LANE
    action = winner_take_all(state[b, r, at], state[b, r, at + 1], state[b, r, at + 2])
    fixed = brain[b, r] == k
    for i in range(9):
        if state[b, r, i] != prev[i]:
            fixed = False
    for j in range(7):
        memo_obs[r, j] = obs[b, r, j]
    memo[r, 0] = 1 if fixed else 0
    memo[r, 1] = rflag_signal
    memo[r, 2] = action
    return action


@njit(cache=True, error_model="numpy", inline="always")
def remembered_action_16(b, r, obs, rflag_signal, n_brains, wpack, bpack, state, brain, prev, memo_obs, memo,
                         by_net=False):
    """`remembered_action` for packed networks (`pack_networks`): the same memo, brain switch and results, the
    two steps in `_network_16`.  state (B, R, 16) float32 holds hidden nodes 0..8, outputs 9..11 and their net
    inputs 12..14."""
    k = brain[b, r]
    if _recall_16(b, r, obs, rflag_signal, n_brains, state, brain, prev, memo_obs, memo):
        return memo[r, 2]
    unit = (b * state.shape[1] + r) * n_brains + brain[b, r]
    _network_16(state, (b * state.shape[1] + r) * LANES, wpack, unit * LANES * LANES, bpack, unit * LANES, obs,
                (b * obs.shape[1] + r) * obs.shape[2], TABLE)
    return _remember_16(b, r, k, obs, rflag_signal, state, brain, prev, memo_obs, memo, by_net)


@njit(cache=True, error_model="numpy", inline="always")
def _step_pending_16(n, pending, obs, rflag, flag, state, brain, prev, memo_obs, memo, wpack, bpack, b, by_net):
    """Step the n (1..3) networks listed in `pending` together, then remember each one's action."""
    if n == 3:
        _networks_16_3(state, wpack, bpack, obs, TABLE, pending)
    elif n == 2:
        _networks_16_2(state, wpack, bpack, obs, TABLE, pending)
    else:
        _network_16(state, pending[0, 0], wpack, pending[0, 1], bpack, pending[0, 2], obs, pending[0, 3], TABLE)
    for q in range(n):
        r = pending[q, 4]
        _remember_16(b, r, pending[q, 5], obs, rflag[b, r, flag], state, brain, prev[r], memo_obs, memo, by_net)


@njit(cache=True, error_model="numpy", inline="always")
def remembered_actions_16(b, obs, rflag, flag, n_brains, wpack, bpack, state, brain, prev, memo_obs, memo, pending,
                          by_net=False, robots=ALL_ROBOTS):
    """`remembered_action_16` for every robot of episode b at once: each robot's action in memo[r, 2].

    The robots' networks are independent (each reads its own inputs, state and weights), so the ones the memo
    cannot answer step together, up to three at a time (`_network_16_ir` overlaps their dependency chains):
    the same operations per robot as one by one, so the same bits.  rflag[b, r, flag] is robot r's come-home
    signal; prev (R, 9) float32 and pending (R, PENDING) int64 are scratch.  Only the robots whose bit is set in
    `robots` (bit r: robot r) step; the others are left as they are (kernels.run_controllers' robot episodes)."""
    n_robots = state.shape[1]
    n = 0
    for r in range(n_robots):
        if not (robots >> r) & 1:
            continue
        k = brain[b, r]
        if _recall_16(b, r, obs, rflag[b, r, flag], n_brains, state, brain, prev[r], memo_obs, memo):
            continue
        unit = (b * n_robots + r) * n_brains + brain[b, r]
        pending[n, 0] = (b * n_robots + r) * LANES
        pending[n, 1] = unit * LANES * LANES
        pending[n, 2] = unit * LANES
        pending[n, 3] = (b * obs.shape[1] + r) * obs.shape[2]
        pending[n, 4] = r
        pending[n, 5] = k
        n += 1
        if n == 3:
            _step_pending_16(n, pending, obs, rflag, flag, state, brain, prev, memo_obs, memo, wpack, bpack, b, by_net)
            n = 0
    if n > 0:
        _step_pending_16(n, pending, obs, rflag, flag, state, brain, prev, memo_obs, memo, wpack, bpack, b, by_net)
