"""The inlined expf, its 8-lane form and the 8-lane sigmoid return the C library's numbers to the bit.

benchmarks/check_expf.py checks all 2^32 float32 inputs (0 differ on this machine's glibc); here a few million
random bit patterns and every special region (overflow, underflow, the slow path's edges, inf, NaN).
"""
import numpy as np
import pytest

from mahn_envs.core.expf import (
    MAY_UNDERFLOW,
    OVERFLOW,
    UNDERFLOW,
    expf_8_array,
    expf_array,
    libm_expf_array,
    libm_sigmoid_array,
    sigmoid_8_array,
)


def _inputs() -> np.ndarray:
    rng = np.random.default_rng(11)
    random_bits = rng.integers(0, 1 << 32, 1 << 21, dtype=np.uint64).astype(np.uint32).view(np.float32)
    edges = np.array([88.0, -88.0, OVERFLOW, UNDERFLOW, MAY_UNDERFLOW, 0.0, -0.0, np.inf, -np.inf, np.nan],
                     dtype=np.float32)
    near = (edges[:5, None].view(np.uint32) + np.arange(-300, 301, dtype=np.int64).astype(np.uint32)[None, :])
    dense = np.linspace(-110.0, 95.0, 1 << 20, dtype=np.float32)
    x = np.concatenate([random_bits, edges, near.ravel().view(np.float32), dense])
    return x[: len(x) // 8 * 8]


def _same(a: np.ndarray, b: np.ndarray) -> bool:
    return bool(np.all((a.view(np.uint32) == b.view(np.uint32)) | (np.isnan(a) & np.isnan(b))))


@pytest.mark.parametrize("ours_fn", [expf_array, expf_8_array], ids=["expf", "expf_8"])
def test_expf_matches_the_library_bitwise(ours_fn):
    """The scalar expf (the networks, the CPPNs) and its 8-lane form (the lean GRU: baselines/lean/gru_kernel.py)."""
    x = _inputs()
    ours, lib = np.empty_like(x), np.empty_like(x)
    ours_fn(x, ours)
    libm_expf_array(x, lib)
    assert _same(ours, lib)
    assert np.isinf(lib).any() and (lib == 0).any() and (lib.view(np.uint32) == 1).any()  # all paths taken


def test_sigmoid_8_matches_the_scalar_library_formula_bitwise():
    x = _inputs()
    ours, lib = np.empty_like(x), np.empty_like(x)
    sigmoid_8_array(x, ours)
    libm_sigmoid_array(x, lib)
    assert _same(ours, lib)
    assert (lib == 0).any() and (lib == 1).any() and np.isnan(lib).any()

