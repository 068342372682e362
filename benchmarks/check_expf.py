"""Exhaustive check: mahn_envs.core.expf against the C library's expf for every one of the 2^32 float32.

Checks the inlined `expf` against the library's, and the 8-lane `sigmoid_8` against the scalar sigmoid
formula with the library's expf.  Evolution runs stay bit-identical only if they return the library's numbers.
Runs a few minutes on one core; prints the number of differing inputs (must be 0 for both).
Usage: python benchmarks/check_expf.py [--chunk-bits 24]
"""
from __future__ import annotations

import argparse
import os
import sys
import time

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(__file__), ".."))

from mahn_envs.core.expf import expf_array, libm_expf_array, libm_sigmoid_array, sigmoid_8_array  # noqa: E402


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--chunk-bits", type=int, default=24)
    args = ap.parse_args()
    n = 1 << args.chunk_bits
    for name, ours_fn, lib_fn in (("expf", expf_array, libm_expf_array),
                                  ("sigmoid_8", sigmoid_8_array, libm_sigmoid_array)):
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
