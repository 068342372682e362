"""Which single-precision matrix product (BLAS `sgemm`, Fortran interface) the compiled GRU calls every tick.

Why not numba's `np.dot`: it calls scipy's OpenBLAS, which on one thread takes 56 us for the IPPO-GRU update's
per-tick product at hidden size 128 (48 x 128 times 128 x 384), where torch's own MKL takes 31 us (measured on the
Intel Xeon host, AVX-512, both cores loaded; 1.3-1.8x on the shapes of hidden 128, about the same at 64).  torch
bundles MKL in its x86-64 builds and exports its Fortran BLAS, so the kernels call that `sgemm_` through a function
pointer; where torch has no MKL (other platforms), they call scipy's `sgemm` (the one `np.dot` calls) the same way.

Both compute each element as a dot product of float32 values; the order of the additions is the library's.  On the
Intel Xeon host the two gave the same bits on every shape of the lean methods (forward 48 / 96 x 128 x 384, backward
48 / 96 x 384 x 128) and three updates of an IPPO-GRU run at hidden 128 gave bit-identical weights, so runs made
with `np.dot` before continue unchanged there; on another host or library the last bits may differ, as between
any two BLAS builds.
"""
from __future__ import annotations

import ctypes
import functools
import glob
import os

import numpy as np
from numba import njit

_ARGS = [ctypes.c_void_p] * 13


def _torch_mkl() -> ctypes._CFuncPtr | None:  # type: ignore[name-defined]
    """torch's MKL `sgemm_` (its argument types set), or None where torch is not built with MKL or does not export
    it."""
    try:
        import torch
    except ImportError:
        return None
    if not torch.backends.mkl.is_available():
        return None
    for path in sorted(glob.glob(os.path.join(os.path.dirname(torch.__file__), "lib", "libtorch_cpu.*"))):
        try:
            lib = ctypes.CDLL(path)
        except OSError:
            continue
        fn = getattr(lib, "sgemm_", None)
        if fn is not None:
            fn.argtypes, fn.restype = _ARGS, None
            return fn
    return None


def _scipy_openblas() -> ctypes._CFuncPtr:  # type: ignore[name-defined]
    """scipy's `sgemm` (its OpenBLAS), from the capsule `scipy.linalg.cython_blas` exports (as numba finds it)."""
    from scipy.linalg import cython_blas

    capsule = cython_blas.__pyx_capi__["sgemm"]  # type: ignore[attr-defined]
    get_name = ctypes.pythonapi.PyCapsule_GetName
    get_name.restype, get_name.argtypes = ctypes.c_char_p, [ctypes.py_object]
    get_pointer = ctypes.pythonapi.PyCapsule_GetPointer
    get_pointer.restype, get_pointer.argtypes = ctypes.c_void_p, [ctypes.py_object, ctypes.c_char_p]
    address = get_pointer(capsule, get_name(capsule))
    return ctypes.CFUNCTYPE(None, *_ARGS)(address)


@njit(cache=True, error_model="numpy", inline="always")
def scratch():
    """The dimensions (int64, read alike by LP64 and ILP64 interfaces), the scalars 1 and 0, and the 'N' (78) that
    `product` passes by reference: allocated once per kernel call, not per product."""
    return (np.zeros(3, dtype=np.int64), np.array([1.0, 0.0], dtype=np.float32), np.full(1, 78, dtype=np.uint8))


@njit(cache=True, error_model="numpy", inline="always")
def product(fn, a, b, c, blas):
    """c = a @ b (C-contiguous float32 matrices) through the Fortran sgemm `fn`: column-major c^T = b^T a^T.
    blas: `scratch()`."""
    if not (a.flags.c_contiguous and b.flags.c_contiguous and c.flags.c_contiguous):
        raise ValueError("the GRU kernel's matrix product takes C-contiguous matrices only")
    dims, scalars, trans = blas
    dims[0] = b.shape[1]
    dims[1] = a.shape[0]
    dims[2] = a.shape[1]
    fn(trans.ctypes.data, trans.ctypes.data, dims.ctypes.data, dims[1:].ctypes.data, dims[2:].ctypes.data,
       scalars.ctypes.data, b.ctypes.data, dims.ctypes.data, a.ctypes.data, dims[2:].ctypes.data,
       scalars[1:].ctypes.data, c.ctypes.data, dims.ctypes.data)


@njit(cache=True, error_model="numpy")
def matmul(fn, a, b, c):
    """One `product` (for the check below and the tests)."""
    product(fn, a, b, c, scratch())


def _works(fn: ctypes._CFuncPtr) -> bool:  # type: ignore[name-defined]
    """A product of known matrices through `fn` as the kernels call it equals numpy's."""
    rng = np.random.default_rng(0)
    a = rng.standard_normal((3, 5)).astype(np.float32)
    b = rng.standard_normal((5, 4)).astype(np.float32)
    c = np.zeros((3, 4), dtype=np.float32)
    matmul(fn, a, b, c)
    return bool(np.allclose(c, a @ b, rtol=1e-5, atol=1e-6))


@functools.cache
def sgemm() -> tuple[str, ctypes._CFuncPtr]:  # type: ignore[name-defined]
    """(name, function) of the sgemm the compiled GRU calls: "mkl" (torch's) where it is there and works, else
    "openblas" (scipy's).  Chosen once per process."""
    fn = _torch_mkl()
    if fn is not None and _works(fn):
        return "mkl", fn
    return "openblas", _scipy_openblas()
