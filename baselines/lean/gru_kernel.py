"""The GRU recurrence of the lean PPO methods as two compiled loops (forward, backward), behind torch's autograd.

Why: on one CPU thread, `nn.GRU` spends an IPPO-GRU update mostly in per-tick operator overhead.  An update
runs 16 passes (actor and critic, 2 minibatches, 4 epochs) forward and backward over 682 ticks x 96 sequences
of 64 units: 0.33 CPU-s a pass with `nn.GRU` (a hand-written backward in torch ops: the same), about 0.13 CPU-s
here (`benchmarks/bench_rl.py`).  Each tick is one small matrix product (BLAS `sgemm` through a function pointer:
torch's MKL where torch has it, see `sgemm.py`) and passes over the units whose exponentials run eight at a time
(`expf_8`, the same bits as the scalar `expf` of `mahn_envs.core.expf`); the backward's units eight lanes at a time
too (`_backward_cells_8`).  Against the kernel of 463afe4 (np.dot, one unit at a time) the results are the same bits
on the measured host (tests: the passes against the unit-by-unit formula; three updates of each method compared).

The function is `nn.GRU`'s (one layer, gates in torch's order r, z, n):
    r = sigmoid(gi_r + gh_r),  z = sigmoid(gi_z + gh_z),  n = tanh(gi_n + r * gh_n),  h' = n + z (h - n)
with gi = W_ih x + b_ih (computed by torch for all ticks at once, so its gradient is autograd's) and
gh = W_hh h + b_hh.  The parameters stay the `nn.GRU` module's, so state dicts and checkpoints are unchanged;
results agree with `nn.GRU` to float32 rounding (tests/baselines/test_gru_kernel.py), not bit for bit.
"""
from __future__ import annotations

import numpy as np
import scipy.linalg.cython_blas  # noqa: F401  scipy's OpenBLAS (the fallback sgemm): loaded before its threads are limited
import torch
from llvmlite import ir
from numba import njit, types
from numba.extending import intrinsic
from threadpoolctl import threadpool_limits
from torch import nn

from mahn_envs.core.expf import TABLE, expf, expf_8

from .sgemm import product, scratch, sgemm

_ONE = np.float32(1.0)
_TWO = np.float32(2.0)
_MINUS_TWO = np.float32(-2.0)


def limit_blas_threads(n: int) -> None:
    """Run the BLAS libraries of this process (numpy's, and scipy's that the kernels call where torch has no MKL)
    on n threads; torch's MKL, which they call otherwise, follows `torch.set_num_threads` (the callers set both).
    Why: OpenBLAS starts a thread per core for a product as small as one tick's; on a shared 2-core machine that
    made each product 10x slower (measured: 340 against 32 us)."""
    threadpool_limits(limits=max(1, int(n)), user_api="blas")


@njit(cache=True, error_model="numpy", inline="always")
def _expf_range(buf, lo, hi):
    """buf[lo:hi] = expf(buf[lo:hi]) in place, eight at a time (`expf_8`), the rest one by one: the same bits."""
    j = lo
    while j + 8 <= hi:
        expf_8(buf, j, TABLE)
        j += 8
    while j < hi:
        buf[j] = expf(buf[j])
        j += 1


@njit(cache=True, error_model="numpy", inline="always")
def _cells(gi, gh, b_hh, h_prev, r, z, n, ghn, h_next, arg):
    """One sequence's units at one tick: r = sigmoid(a_r), z = sigmoid(a_z) with sigmoid(a) = 1 / (1 + expf(-a)),
    n = tanh(a_n) as 2 sigmoid(2 a_n) - 1 (exact at both saturations, where expf gives inf or 0; within 2e-7 of
    tanh elsewhere), h' = n + z (h - n).  In three passes, so that the exponentials run eight at a time: the gates'
    exponents, then r, z and the candidate's exponent, then n and h'.  Each value is computed by the same float32
    operations as unit by unit (tests/baselines/test_gru_kernel.py: the same bits).  arg: scratch of 3H."""
    H = h_prev.shape[0]
    for j in range(2 * H):
        arg[j] = -(gi[j] + (gh[j] + b_hh[j]))
    _expf_range(arg, 0, 2 * H)
    for j in range(H):
        rr = _ONE / (_ONE + arg[j])
        g = gh[2 * H + j] + b_hh[2 * H + j]
        r[j] = rr
        z[j] = _ONE / (_ONE + arg[H + j])
        ghn[j] = g
        arg[2 * H + j] = _MINUS_TWO * (gi[2 * H + j] + rr * g)
    _expf_range(arg, 2 * H, 3 * H)
    for j in range(H):
        nn_ = _TWO / (_ONE + arg[2 * H + j]) - _ONE
        n[j] = nn_
        h_next[j] = nn_ + z[j] * (h_prev[j] - nn_)


@njit(cache=True, error_model="numpy")
def gru_forward(gi, h0, w_hh_t, b_hh, hs, r, z, n, ghn, fn):
    """gi (T, N, 3H), h0 (N, H), w_hh_t (H, 3H) = W_hh transposed, b_hh (3H,) -> hs (T+1, N, H) with hs[0] = h0
    and hs[t+1] the state after tick t; r, z, n, ghn (T, N, H) the gates and gh_n, kept for the backward.
    fn: the sgemm (`sgemm.sgemm`)."""
    T, N, H3 = gi.shape
    hs[0] = h0
    gh = np.empty((N, H3), dtype=np.float32)
    arg = np.empty(H3, dtype=np.float32)
    blas = scratch()
    for t in range(T):
        product(fn, hs[t], w_hh_t, gh, blas)
        for i in range(N):
            _cells(gi[t, i], gh[i], b_hh, hs[t, i], r[t, i], z[t, i], n[t, i], ghn[t, i], hs[t + 1, i], arg)


@intrinsic
def _backward_cells_8(typingctx, dh, dy, z, n, r, h, g, dgi, dgh, j):
    """Units j..j+7 of one sequence's backward step at one tick, eight lanes at once: exactly the float32
    operations of the unit-by-unit loop in `gru_backward` (each product and sum in its order, none fused), from
    the rows (1-D, C-contiguous float32) of dh (in: the gradient of the next state; out: of this one), dy, the
    gates z, n, r, the state h before the tick and gh_n (g), into the rows of dgi and dgh (3H each).
    Why by hand: the loop reads seven arrays and writes three, more than the compiler's run-time alias checks
    allow, so it stayed scalar (8.9 ns a unit measured, against 3.5 for the forward's)."""
    rows = (dh, dy, z, n, r, h, g, dgi, dgh)
    if not all(isinstance(a, types.Array) and a.dtype == types.float32 and a.ndim == 1 and a.layout == "C"
               for a in rows) or not isinstance(j, types.Integer):
        return None
    sig = types.void(*rows, types.intp)

    def codegen(context, builder, signature, args):
        vf = ir.VectorType(ir.FloatType(), 8)
        ptrs = [context.make_array(signature.args[k])(context, builder, args[k]).data for k in range(9)]
        at = args[9]
        n_units = context.make_array(signature.args[0])(context, builder, args[0]).shape
        H = builder.extract_value(n_units, 0)

        def addr(ptr, offset):
            return builder.bitcast(builder.gep(ptr, [offset], inbounds=True), vf.as_pointer())

        def load(k):
            return builder.load(addr(ptrs[k], at), align=4)

        one = ir.Constant(vf, [1.0] * 8)
        dh_v, dy_v, zz, nn_, rr, h_v, g_v = (load(k) for k in range(7))
        d = builder.fadd(dh_v, dy_v)
        dn = builder.fmul(builder.fmul(d, builder.fsub(one, zz)), builder.fsub(one, builder.fmul(nn_, nn_)))
        dz = builder.fmul(builder.fmul(builder.fmul(d, builder.fsub(h_v, nn_)), zz), builder.fsub(one, zz))
        dr = builder.fmul(builder.fmul(builder.fmul(dn, g_v), rr), builder.fsub(one, rr))
        at_z = builder.add(at, H)
        at_n = builder.add(at_z, H)
        for k, values in ((7, (dr, dz, dn)), (8, (dr, dz, builder.fmul(dn, rr)))):
            for offset, v in zip((at, at_z, at_n), values):
                builder.store(v, addr(ptrs[k], offset), align=4)
        builder.store(builder.fmul(d, zz), addr(ptrs[0], at), align=4)
        return context.get_dummy_value()

    return sig, codegen


@njit(cache=True, error_model="numpy")
def gru_backward(dy, dh, w_hh, hs, r, z, n, ghn, dgi, dgh, fn):
    """The gradients of `gru_forward`: dy (T, N, H) of the outputs hs[1:], dh (N, H) of the last state (in; out:
    of h0), w_hh (3H, H) -> dgi and dgh (T, N, 3H), the gradients of gi and of gh = W_hh h + b_hh per tick."""
    T, N, H = r.shape
    back = np.empty((N, H), dtype=np.float32)
    blas = scratch()
    for t in range(T - 1, -1, -1):
        for i in range(N):
            dh_i, dy_i, z_i, n_i, r_i, h_i, g_i = dh[i], dy[t, i], z[t, i], n[t, i], r[t, i], hs[t, i], ghn[t, i]
            dgi_i, dgh_i = dgi[t, i], dgh[t, i]
            j = 0
            while j + 8 <= H:
                _backward_cells_8(dh_i, dy_i, z_i, n_i, r_i, h_i, g_i, dgi_i, dgh_i, j)
                j += 8
            while j < H:
                d = dh_i[j] + dy_i[j]
                zz = z_i[j]
                nn_ = n_i[j]
                rr = r_i[j]
                dn = d * (_ONE - zz) * (_ONE - nn_ * nn_)
                dz = d * (h_i[j] - nn_) * zz * (_ONE - zz)
                dr = dn * g_i[j] * rr * (_ONE - rr)
                dgi_i[j] = dr
                dgi_i[H + j] = dz
                dgi_i[2 * H + j] = dn
                dgh_i[j] = dr
                dgh_i[H + j] = dz
                dgh_i[2 * H + j] = dn * rr
                dh_i[j] = d * zz
                j += 1
        product(fn, dgh[t], w_hh, back, blas)
        dh += back


def _run_forward(gi: torch.Tensor, h0: torch.Tensor, w_hh: torch.Tensor, b_hh: torch.Tensor, hs: torch.Tensor,
                 r: np.ndarray, z: np.ndarray, n: np.ndarray, ghn: np.ndarray) -> None:
    """`gru_forward` on torch tensors (h0 (1, N, H)): states into hs (T + 1, N, H), gates into r, z, n, ghn."""
    gru_forward(gi.detach().contiguous().numpy(), h0[0].detach().contiguous().numpy(),
                w_hh.detach().t().contiguous().numpy(), b_hh.detach().contiguous().numpy(), hs.numpy(), r, z, n, ghn,
                sgemm()[1])


class GRURecurrence(torch.autograd.Function):
    """(gi (T, N, 3H), h0 (1, N, H), W_hh (3H, H), b_hh (3H,)) -> (outputs (T, N, H), last state (1, N, H))."""

    @staticmethod
    def forward(ctx, gi, h0, w_hh, b_hh):  # type: ignore[override]
        T, N, H3 = gi.shape
        H = H3 // 3
        hs = torch.empty(T + 1, N, H)
        r, z, n, ghn = torch.empty(T, N, H), torch.empty(T, N, H), torch.empty(T, N, H), torch.empty(T, N, H)
        _run_forward(gi, h0, w_hh, b_hh, hs, r.numpy(), z.numpy(), n.numpy(), ghn.numpy())
        ctx.save_for_backward(w_hh, hs, r, z, n, ghn)
        return hs[1:], hs[T:].clone()

    @staticmethod
    def backward(ctx, dy, dh_last):  # type: ignore[override]
        w_hh, hs, r, z, n, ghn = ctx.saved_tensors
        T, N, H = r.shape
        dy = torch.zeros(T, N, H) if dy is None else dy.contiguous()
        dh = torch.zeros(N, H) if dh_last is None else dh_last[0].contiguous().clone()
        dgi, dgh = torch.empty(T, N, 3 * H), torch.empty(T, N, 3 * H)
        gru_backward(dy.numpy(), dh.numpy(), w_hh.detach().contiguous().numpy(), hs.numpy(), r.numpy(), z.numpy(),
                     n.numpy(), ghn.numpy(), dgi.numpy(), dgh.numpy(), sgemm()[1])
        flat = dgh.view(T * N, 3 * H)
        return dgi, dh[None], flat.t() @ hs[:T].reshape(T * N, H), flat.sum(0)


def gru_sequence(gru: nn.GRU, x: torch.Tensor, h: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
    """`gru(x, h)` of a one-layer `nn.GRU` (x (T, N, in), h (1, N, H)) through the compiled recurrence."""
    if gru.num_layers != 1 or gru.bidirectional or gru.batch_first or not gru.bias:
        raise ValueError("gru_sequence runs one-layer, one-directional GRUs with biases on (T, N, in) inputs")
    if x.dtype != torch.float32 or h.dtype != torch.float32 or gru.weight_hh_l0.dtype != torch.float32:
        raise TypeError(f"gru_sequence computes in float32; got inputs {x.dtype}, state {h.dtype}, "
                        f"weights {gru.weight_hh_l0.dtype}")
    p = dict(gru.named_parameters())  # typed as tensors (module attributes are Tensor | Module to mypy)
    w_ih, w_hh, b_ih, b_hh = p["weight_ih_l0"], p["weight_hh_l0"], p["bias_ih_l0"], p["bias_hh_l0"]
    T, N, _ = x.shape
    gi = torch.addmm(b_ih, x.reshape(T * N, -1), w_ih.t()).view(T, N, -1)
    if torch.is_grad_enabled():
        out, last = GRURecurrence.apply(gi, h, w_hh, b_hh)
        return out, last
    # no gradient to take (a rollout's tick): the same loop, its gates into scratch
    H = gru.hidden_size
    hs, gates = torch.empty(T + 1, N, H), np.empty((4, T, N, H), dtype=np.float32)
    _run_forward(gi, h, w_hh, b_hh, hs, *gates)
    return hs[1:], hs[T:]
