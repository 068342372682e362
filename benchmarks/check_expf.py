"""Exhaustive check: mahn_envs.core.expf against the C library's expf for every one of the 2^32 float32.

Checks the inlined `expf` and its 8-lane form `expf_8` (the lean PPO's GRU) against the library's, the 8-lane
`sigmoid_8` against the scalar sigmoid formula with the library's expf, and the CPPN relaxation's vector activations
(mahn_evo.cppn.relax: bipolar sigmoid, gaussian and sigmoid through `expf_ir` in 64 lanes; sin(2x) through
`sinf.sin2x_ir` where |2x| < 120) against their scalar formulas with the library's expf and sinf.  Evolution runs
stay bit-identical only if they return the library's numbers.  Runs a few minutes per check on one core; prints the
number of differing inputs (must be 0 for every check).
Usage: python benchmarks/check_expf.py [--chunk-bits 24]
"""
from __future__ import annotations

import argparse
import os
import sys
import time

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(__file__), ".."))

import math  # noqa: E402

from numba import njit  # noqa: E402

from mahn_envs.core.expf import expf_8_array, expf_array, libm_expf_array, libm_sigmoid_array, sigmoid_8_array  # noqa: E402
from mahn_evo.cppn.relax import LANES, _activate, activate_row  # noqa: E402


@njit(cache=True, error_model="numpy")
def _lanes_array(code, x, out):
    """out = the CPPN activation `code` of x through the relaxation's vector intrinsics, LANES at a time."""
    block = x.reshape(-1, LANES).copy()
    for i in range(block.shape[0]):
        activate_row(block, i, code)
    out[:] = block.reshape(-1)


@njit(cache=True, error_model="numpy")
def _libm_activation_array(code, x, out):
    """out = the CPPN activation `code` of x by its scalar formula with the C library's expf (math.exp)."""
    f = np.float32
    for i in range(x.shape[0]):
        if code == 0:
            out[i] = f(2.0) / (f(1.0) + f(math.exp(f(-4.9) * x[i]))) - f(1.0)
        elif code == 1:
            y = f(2.5) * x[i]
            out[i] = f(2.0) * f(math.exp(-(y * y))) - f(1.0)
        elif code == 3:
            out[i] = f(math.sin(f(2.0) * x[i]))  # the library's sinf
        else:
            out[i] = f(1.0) / (f(1.0) + f(math.exp(f(-4.9) * x[i])))


@njit(cache=True, error_model="numpy")
def _scalar_activation_array(code, x, out):
    """out = `_activate(code, x)`, the relaxation's scalar activation (the inlined expf)."""
    for i in range(x.shape[0]):
        out[i] = _activate(code, x[i])


def _check_cppn(code: int):
    return (lambda x, out: _lanes_array(code, x, out)), (lambda x, out: _libm_activation_array(code, x, out))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--chunk-bits", type=int, default=24)
    args = ap.parse_args()
    n = 1 << args.chunk_bits
    checks = [("expf", expf_array, libm_expf_array), ("expf_8", expf_8_array, libm_expf_array),
              ("sigmoid_8", sigmoid_8_array, libm_sigmoid_array)]
    checks += [(f"CPPN {name} lanes", *_check_cppn(code))
               for code, name in ((0, "bipolar sigmoid"), (1, "gaussian"), (3, "sine"), (7, "sigmoid"))]
    for name, ours_fn, lib_fn in checks:
        ours = np.empty(n, dtype=np.float32)
        lib = np.empty(n, dtype=np.float32)
        bad = 0
        t0 = time.perf_counter()
        for start in range(0, 1 << 32, n):
            x = np.arange(start, start + n, dtype=np.uint64).astype(np.uint32).view(np.float32)
            ours_fn(x, ours)
            lib_fn(x, lib)
            wrong = (ours.view(np.uint32) != lib.view(np.uint32)) & ~(np.isnan(ours) & np.isnan(lib))
            if wrong.any():
                i = int(np.argmax(wrong))
                print(f"{name} differs at {x[i]!r} ({x.view(np.uint32)[i]:#010x}): ours {ours[i]!r}, library "
                      f"{lib[i]!r}")
            bad += int(wrong.sum())
        print(f"{name}: {1 << 32} float32 inputs checked in {time.perf_counter() - t0:.0f} s: {bad} differ from "
              "the library", flush=True)

if __name__ == "__main__":
    main()
