"""Keep a training process's freed memory for reuse (glibc's malloc), so large tensors stop costing page faults.

Why: a lean PPO update allocates and frees the same large buffers in every minibatch (per-tick gates and their
gradients, 17-50 MB each).  glibc serves blocks above its mmap threshold (at most 32 MB) with fresh mappings and
returns them to the system when freed, so every pass touches new pages: one page fault per 4 KB, which on this
project's shared 2-core machine made a 50 MB copy take 125 ms instead of 8.  With mappings off and trimming off,
freed blocks stay in the heap and the next minibatch reuses them.  Measured on an IPPO-GRU update (32 episodes):
the PPO epochs take 3.3 CPU-s instead of 4.6 (`benchmarks/bench_rl.py`).  The heap then keeps its largest size
until the process ends (a few hundred MB for the default sizes).
"""
from __future__ import annotations

import ctypes
import ctypes.util
import sys

#: mallopt parameters (glibc's malloc.h)
M_TRIM_THRESHOLD = -1
M_MMAP_MAX = -4


def keep_freed_memory() -> bool:
    """Turn off glibc's mmap for large blocks and its trimming of the heap, for this process.  Returns whether
    it could (False off Linux or without glibc's `mallopt`: nothing changes, only speed)."""
    if not sys.platform.startswith("linux"):
        return False
    try:
        libc = ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6")
        mallopt = libc.mallopt
    except (OSError, AttributeError):
        return False
    mallopt.argtypes = [ctypes.c_int, ctypes.c_int]
    mallopt.restype = ctypes.c_int
    return bool(mallopt(M_MMAP_MAX, 0)) and bool(mallopt(M_TRIM_THRESHOLD, 2**31 - 1))
