"""The compiled GRU recurrence (baselines/lean/gru_kernel.py) against torch's nn.GRU: the same outputs, last state and
gradients (to float32 rounding), the rollout's no-graph path bit for bit the training path, and the allocator
setting (baselines/lean/allocator.py) in effect."""
import numpy as np
import pytest

torch = pytest.importorskip("torch")
pytest.importorskip("threadpoolctl")
from torch import nn  # noqa: E402

from baselines.lean.allocator import keep_freed_memory  # noqa: E402
from baselines.lean.gru_kernel import gru_sequence, limit_blas_threads  # noqa: E402


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
