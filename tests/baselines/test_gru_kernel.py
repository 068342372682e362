"""The compiled GRU recurrence (baselines/lean/gru_kernel.py) against torch's nn.GRU: the same outputs, last state and
gradients (to float32 rounding); its eight-lane passes against the unit-by-unit formula (the same bits); the sgemm
it calls (baselines/lean/sgemm.py); the rollout's no-graph path bit for bit the training path, and the allocator
setting (baselines/lean/allocator.py) in effect."""
import numpy as np
import pytest

torch = pytest.importorskip("torch")
pytest.importorskip("threadpoolctl")
from numba import njit  # noqa: E402
from torch import nn  # noqa: E402

from baselines.lean import gru_kernel  # noqa: E402
from baselines.lean.allocator import keep_freed_memory  # noqa: E402
from baselines.lean.gru_kernel import gru_sequence, limit_blas_threads  # noqa: E402
from baselines.lean.sgemm import _scipy_openblas, _torch_mkl, matmul, product, scratch, sgemm  # noqa: E402
from mahn_envs.core.expf import expf  # noqa: E402

_ONE, _TWO = np.float32(1.0), np.float32(2.0)


@njit(cache=True, error_model="numpy")
def _forward_unit_by_unit(gi, h0, w_hh_t, b_hh, hs, r, z, n, ghn, fn):
    """The recurrence one unit at a time with the scalar expf (the kernel before its eight-lane passes)."""
    T, N, H3 = gi.shape
    H = H3 // 3
    hs[0] = h0
    gh = np.empty((N, H3), dtype=np.float32)
    for t in range(T):
        product(fn, hs[t], w_hh_t, gh, scratch())
        for i in range(N):
            for j in range(H):
                rr = _ONE / (_ONE + expf(-(gi[t, i, j] + (gh[i, j] + b_hh[j]))))
                zz = _ONE / (_ONE + expf(-(gi[t, i, H + j] + (gh[i, H + j] + b_hh[H + j]))))
                g = gh[i, 2 * H + j] + b_hh[2 * H + j]
                nn_ = _TWO / (_ONE + expf(-_TWO * (gi[t, i, 2 * H + j] + rr * g))) - _ONE
                r[t, i, j], z[t, i, j], n[t, i, j], ghn[t, i, j] = rr, zz, nn_, g
                hs[t + 1, i, j] = nn_ + zz * (hs[t, i, j] - nn_)


@njit(cache=True, error_model="numpy")
def _backward_unit_by_unit(dy, dh, w_hh, hs, r, z, n, ghn, dgi, dgh, fn):
    T, N, H = r.shape
    back = np.empty((N, H), dtype=np.float32)
    for t in range(T - 1, -1, -1):
        for i in range(N):
            for j in range(H):
                d = dh[i, j] + dy[t, i, j]
                zz, nn_, rr = z[t, i, j], n[t, i, j], r[t, i, j]
                dn = d * (_ONE - zz) * (_ONE - nn_ * nn_)
                dz = d * (hs[t, i, j] - nn_) * zz * (_ONE - zz)
                dr = dn * ghn[t, i, j] * rr * (_ONE - rr)
                dgi[t, i, j], dgi[t, i, H + j], dgi[t, i, 2 * H + j] = dr, dz, dn
                dgh[t, i, j], dgh[t, i, H + j], dgh[t, i, 2 * H + j] = dr, dz, dn * rr
                dh[i, j] = d * zz
        product(fn, dgh[t], w_hh, back, scratch())
        dh += back


@pytest.mark.parametrize("T,N,H,scale", [(30, 5, 16, 1.0), (20, 3, 13, 4.0), (12, 7, 40, 30.0), (3, 2, 5, 1.0)])
def test_eight_lane_passes_match_the_unit_by_unit_formula_bitwise(T, N, H, scale):
    """Forward and backward give the bits of the unit-by-unit loops (lanes and tails; saturated gates, inf)."""
    rng = np.random.default_rng(H)
    gi = (rng.standard_normal((T, N, 3 * H)) * scale).astype(np.float32)
    gi[0, 0, :3] = [np.inf, -np.inf, 200.0]
    h0 = rng.standard_normal((N, H)).astype(np.float32)
    w = (rng.standard_normal((3 * H, H)) * scale / np.sqrt(H)).astype(np.float32)
    b = rng.standard_normal(3 * H).astype(np.float32)
    dy = rng.standard_normal((T, N, H)).astype(np.float32)
    fn = sgemm()[1]
    results = []
    for forward, backward in ((gru_kernel.gru_forward, gru_kernel.gru_backward),
                              (_forward_unit_by_unit, _backward_unit_by_unit)):
        hs = np.empty((T + 1, N, H), dtype=np.float32)
        gates = [np.empty((T, N, H), dtype=np.float32) for _ in range(4)]
        forward(gi, h0, np.ascontiguousarray(w.T), b, hs, *gates, fn)
        dh = np.ones((N, H), dtype=np.float32)
        dgi, dgh = np.empty((T, N, 3 * H), dtype=np.float32), np.empty((T, N, 3 * H), dtype=np.float32)
        backward(dy, dh, w, hs, *gates, dgi, dgh, fn)
        results.append([hs, *gates, dh, dgi, dgh])
    for a, c in zip(*results):
        assert np.array_equal(a.view(np.uint32), c.view(np.uint32))
    r = results[0][1]
    assert (r == 1).any() and (r == 0).any()  # saturated gates (expf's special values) were reached
    # the test can fail: another state gives other bits
    assert not np.array_equal(results[0][0][2], results[0][0][1])


def test_sgemm_is_a_working_blas_product():
    """The chosen sgemm, torch's MKL where torch has it, and scipy's OpenBLAS all compute numpy's product."""
    name, fn = sgemm()
    mkl = _torch_mkl()
    assert name == ("mkl" if mkl is not None else "openblas")
    rng = np.random.default_rng(3)
    a = rng.standard_normal((48, 64)).astype(np.float32)
    b = rng.standard_normal((64, 192)).astype(np.float32)
    for f in [fn, _scipy_openblas()] + ([mkl] if mkl is not None else []):
        c = np.full((48, 192), np.nan, dtype=np.float32)
        matmul(f, a, b, c)
        np.testing.assert_allclose(c, a @ b, rtol=1e-4, atol=1e-4)


def _grads(f, gru, x, h0, gy, gh):
    for p in [*gru.parameters(), x, h0]:
        p.grad = None
    y, h = f()
    ((y * gy).sum() + (h * gh).sum()).backward()
    return [y.detach(), h.detach()] + [p.grad.clone() for p in [*gru.parameters(), x, h0]]


@pytest.mark.parametrize("T,N,n_in,H", [(1, 3, 4, 5), (37, 6, 10, 8), (200, 4, 3, 16)])
def test_matches_nn_gru_values_and_gradients(T, N, n_in, H):
    torch.manual_seed(T)
    limit_blas_threads(1)
    gru = nn.GRU(n_in, H)
    for p in gru.parameters():  # larger than the default init, so gates saturate somewhere
        nn.init.normal_(p, std=0.8)
    x = torch.randn(T, N, n_in, requires_grad=True)
    h0 = torch.randn(1, N, H, requires_grad=True)
    gy, gh = torch.randn(T, N, H), torch.randn(1, N, H)
    ref = _grads(lambda: gru(x, h0), gru, x, h0, gy, gh)
    got = _grads(lambda: gru_sequence(gru, x, h0), gru, x, h0, gy, gh)
    names = ["outputs", "last state", "dW_ih", "dW_hh", "db_ih", "db_hh", "dx", "dh0"]
    for name, a, b in zip(names, ref, got):
        assert a.shape == b.shape, name
        # float32 rounding in another order: within 2e-5 of the largest value (summed over up to 800 ticks x rows)
        err = float((a - b).abs().max()) / max(float(a.abs().max()), 1e-6)
        assert err < 2e-5, (name, err)
    # and they differ from a wrong rule (the test can fail): a GRU with another W_hh gives other outputs
    with torch.no_grad():
        gru.weight_hh_l0.mul_(0.5)
    assert not torch.allclose(gru_sequence(gru, x, h0)[0], ref[0], atol=1e-3)


def test_rollout_path_is_the_training_path_bit_for_bit():
    """A rollout steps one tick at a time without a graph; training replays the ticks with one: the same numbers,
    so what is trained is exactly what acted."""
    torch.manual_seed(0)
    gru = nn.GRU(6, 12)
    x = torch.randn(25, 7, 6)
    h0 = torch.randn(1, 7, 12)
    y_train, h_train = gru_sequence(gru, x, h0)
    h = h0
    outs = []
    with torch.no_grad():
        for t in range(x.shape[0]):
            y, h = gru_sequence(gru, x[t:t + 1], h)
            outs.append(y[0])
    assert torch.equal(torch.stack(outs), y_train.detach())
    assert torch.equal(h, h_train.detach())


def test_state_carries_across_ticks():
    """The recurrence has memory: the same input after different histories gives different outputs."""
    torch.manual_seed(1)
    gru = nn.GRU(3, 8)
    a, b = torch.zeros(5, 1, 3), torch.ones(5, 1, 3)
    probe = torch.full((1, 1, 3), 0.3)
    with torch.no_grad():
        ya, _ = gru_sequence(gru, torch.cat([a, probe]), torch.zeros(1, 1, 8))
        yb, _ = gru_sequence(gru, torch.cat([b, probe]), torch.zeros(1, 1, 8))
    assert not torch.allclose(ya[-1], yb[-1])


def test_refuses_gru_it_does_not_implement():
    with pytest.raises(ValueError, match="one-layer"):
        gru_sequence(nn.GRU(3, 4, num_layers=2), torch.zeros(2, 1, 3), torch.zeros(2, 1, 4))
    with pytest.raises(TypeError, match="float32"):
        gru_sequence(nn.GRU(3, 4).double(), torch.zeros(2, 1, 3, dtype=torch.float64),
                     torch.zeros(1, 1, 4, dtype=torch.float64))


def test_allocator_setting_applies_on_linux():
    import sys
    ok = keep_freed_memory()
    assert ok == sys.platform.startswith("linux") or not ok
    big = np.ones(8_000_000, dtype=np.float32)  # still allocates and frees normally
    assert float(big.sum()) == 8_000_000.0


def test_kernel_refuses_a_strided_matrix():
    """The product reads raw memory through BLAS, so a transposed view (not C-contiguous) is refused, not misread."""
    T, N, H = 2, 3, 8
    w = np.ones((3 * H, H), dtype=np.float32)
    hs = np.zeros((T + 1, N, H), dtype=np.float32)
    gates = [np.zeros((T, N, H), dtype=np.float32) for _ in range(4)]
    with pytest.raises(ValueError, match="C-contiguous"):
        gru_kernel.gru_forward(np.zeros((T, N, 3 * H), dtype=np.float32), np.zeros((N, H), dtype=np.float32), w.T,
                               np.zeros(3 * H, dtype=np.float32), hs, *gates, sgemm()[1])
