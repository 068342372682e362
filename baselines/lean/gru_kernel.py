"""The GRU recurrence of the lean PPO methods as two compiled loops (forward, backward), behind torch's autograd.

Why: on one CPU thread, `nn.GRU` spends an IPPO-GRU update mostly in per-tick operator overhead.  An update
runs 16 passes (actor and critic, 2 minibatches, 4 epochs) forward and backward over 682 ticks x 96 sequences
of 64 units: 0.33 CPU-s a pass with `nn.GRU` (a hand-written backward in torch ops: the same), about 0.13 CPU-s
here (`benchmarks/bench_rl.py`).  Each tick is one small matrix product (BLAS, numba's `np.dot`) and one
loop over the units whose exponentials are the inlined, vectorised `expf` of `mahn_envs.core.expf`.

The function is `nn.GRU`'s (one layer, gates in torch's order r, z, n):
    r = sigmoid(gi_r + gh_r),  z = sigmoid(gi_z + gh_z),  n = tanh(gi_n + r * gh_n),  h' = n + z (h - n)
with gi = W_ih x + b_ih (computed by torch for all ticks at once, so its gradient is autograd's) and
gh = W_hh h + b_hh.  The parameters stay the `nn.GRU` module's, so state dicts and checkpoints are unchanged;
results agree with `nn.GRU` to float32 rounding (tests/baselines/test_gru_kernel.py), not bit for bit.
"""
from __future__ import annotations

import numpy as np
import scipy.linalg.cython_blas  # noqa: F401  numba's np.dot calls this BLAS: loaded before its threads are limited
import torch
from numba import njit
from threadpoolctl import threadpool_limits
from torch import nn

from mahn_envs.core.expf import expf

_ONE = np.float32(1.0)
_TWO = np.float32(2.0)


def limit_blas_threads(n: int) -> None:
    """Run the BLAS libraries of this process (numpy's, and scipy's that the kernels call) on n threads.  Why:
    OpenBLAS starts a thread per core for a product as small as one tick's; on a shared 2-core machine that made
    each product 10x slower (measured: 340 against 32 us)."""
    threadpool_limits(limits=max(1, int(n)), user_api="blas")


@njit(cache=True, error_model="numpy", inline="always")
def _sigmoid(a):
    return _ONE / (_ONE + expf(-a))


@njit(cache=True, error_model="numpy", inline="always")
def _tanh(a):
    # 2 sigmoid(2a) - 1: exact at both saturations (expf gives inf / 0 there), within 2e-7 of tanh elsewhere
    return _TWO / (_ONE + expf(-_TWO * a)) - _ONE


@njit(cache=True, error_model="numpy", inline="always")
def _cell(gi, gh, b_hh, h_prev, H, j):
    """Unit j of one tick, from gi (3H,) and gh (3H,) = W_hh h without its bias: (r, z, n, gh_n, h')."""
    rr = _sigmoid(gi[j] + (gh[j] + b_hh[j]))
    zz = _sigmoid(gi[H + j] + (gh[H + j] + b_hh[H + j]))
    g = gh[2 * H + j] + b_hh[2 * H + j]
    nn_ = _tanh(gi[2 * H + j] + rr * g)
    return rr, zz, nn_, g, nn_ + zz * (h_prev - nn_)


@njit(cache=True, error_model="numpy")
def gru_forward(gi, h0, w_hh_t, b_hh, hs, r, z, n, ghn):
    """gi (T, N, 3H), h0 (N, H), w_hh_t (H, 3H) = W_hh transposed, b_hh (3H,) -> hs (T+1, N, H) with hs[0] = h0
    and hs[t+1] the state after tick t; r, z, n, ghn (T, N, H) the gates and gh_n, kept for the backward."""
    T, N, H3 = gi.shape
    H = H3 // 3
    hs[0] = h0
    gh = np.empty((N, H3), dtype=np.float32)
    for t in range(T):
        np.dot(hs[t], w_hh_t, gh)
        for i in range(N):
            for j in range(H):
                r[t, i, j], z[t, i, j], n[t, i, j], ghn[t, i, j], hs[t + 1, i, j] = _cell(
                    gi[t, i], gh[i], b_hh, hs[t, i, j], H, j)


@njit(cache=True, error_model="numpy")
def gru_backward(dy, dh, w_hh, hs, r, z, n, ghn, dgi, dgh):
    """The gradients of `gru_forward`: dy (T, N, H) of the outputs hs[1:], dh (N, H) of the last state (in; out:
    of h0), w_hh (3H, H) -> dgi and dgh (T, N, 3H), the gradients of gi and of gh = W_hh h + b_hh per tick."""
    T, N, H = r.shape
    back = np.empty((N, H), dtype=np.float32)
    for t in range(T - 1, -1, -1):
        for i in range(N):
            for j in range(H):
                d = dh[i, j] + dy[t, i, j]
                zz = z[t, i, j]
                nn_ = n[t, i, j]
                rr = r[t, i, j]
                dn = d * (_ONE - zz) * (_ONE - nn_ * nn_)
                dz = d * (hs[t, i, j] - nn_) * zz * (_ONE - zz)
                dr = dn * ghn[t, i, j] * rr * (_ONE - rr)
                dgi[t, i, j] = dr
                dgi[t, i, H + j] = dz
                dgi[t, i, 2 * H + j] = dn
                dgh[t, i, j] = dr
                dgh[t, i, H + j] = dz
                dgh[t, i, 2 * H + j] = dn * rr
                dh[i, j] = d * zz
        np.dot(dgh[t], w_hh, back)
        dh += back


def _run_forward(gi: torch.Tensor, h0: torch.Tensor, w_hh: torch.Tensor, b_hh: torch.Tensor, hs: torch.Tensor,
                 r: np.ndarray, z: np.ndarray, n: np.ndarray, ghn: np.ndarray) -> None:
    """`gru_forward` on torch tensors (h0 (1, N, H)): states into hs (T + 1, N, H), gates into r, z, n, ghn."""
    gru_forward(gi.detach().contiguous().numpy(), h0[0].detach().contiguous().numpy(),
                w_hh.detach().t().contiguous().numpy(), b_hh.detach().contiguous().numpy(), hs.numpy(), r, z, n, ghn)


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
                     n.numpy(), ghn.numpy(), dgi.numpy(), dgh.numpy())
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
