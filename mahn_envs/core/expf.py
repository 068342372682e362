"""exp of a float32, computed inside the compiled loop with exactly the operations of glibc's expf.

The network's sigmoid needs 21 exponentials per robot-step.  As calls to the C library they cost a call each,
and the compiler must spill every vector register around it; written out here they are a few inlined
floating-point operations that the compiler schedules with the rest of the network.  The results must be the
library's to the bit (evolution runs are reproducible from their seed only while every number stays the same),
so this is glibc's algorithm (sysdeps/ieee754/flt-32/e_expf.c, the build for CPUs with fused multiply-add,
which this machine's libm selects): x/ln2 * 32 = k + r, exp(x) = 2^(k/32) * (1 + C2 r + (C1 + C0 r) r^2) in
double precision, with its table, constants, fused operations and special cases.  benchmarks/check_expf.py
compares it with the library for every float32 input; the tests compare millions of them.
"""
from __future__ import annotations

import math
import struct
from decimal import Decimal, getcontext

import numpy as np
from llvmlite import ir
from numba import njit, types
from numba.core import cgutils
from numba.extending import intrinsic


def _table() -> np.ndarray:
    """tab[i] = bits(2^(i/32)) - (i << 47): 2^(i/32) correctly rounded to double (the library's table)."""
    getcontext().prec = 50
    out = np.empty(32, dtype=np.uint64)
    for i in range(32):
        bits = struct.unpack("<Q", struct.pack("<d", float(Decimal(2) ** (Decimal(i) / 32))))[0]
        out[i] = (bits - (i << 47)) % (1 << 64)
    return out


TABLE = _table()
INV_LN2_N = float.fromhex("0x1.71547652b82fep+5")  # 32 / ln 2
SHIFT = float.fromhex("0x1.8p+52")
C0 = float.fromhex("0x1.c6af84b912394p-20")
C1 = float.fromhex("0x1.ebfce50fac4f3p-13")
C2 = float.fromhex("0x1.62e42ff0c52d6p-6")
OVERFLOW = np.float32(float.fromhex("0x1.62e42ep6"))  # above: +inf
UNDERFLOW = np.float32(float.fromhex("-0x1.9fe368p6"))  # below: 0
MAY_UNDERFLOW = np.float32(float.fromhex("-0x1.9d1d9ep6"))  # below: the smallest subnormal
TINY = np.float32(float.fromhex("0x1p-149"))
SIGMOID_SLOPE32 = np.float32(4.9)  # the network's sigmoid slope


@intrinsic
def _fma(typingctx, a, b, c):
    """a * b + c rounded once (llvm.fma), as the library's vfmadd instructions."""
    if not all(t == types.float64 for t in (a, b, c)):
        return None

    def codegen(context, builder, signature, args):
        d = ir.DoubleType()
        fn = builder.module.declare_intrinsic("llvm.fma", [d], ir.FunctionType(d, [d, d, d]))
        return builder.call(fn, args)

    return types.float64(types.float64, types.float64, types.float64), codegen


@intrinsic
def _bits(typingctx, x):
    """The IEEE bit pattern of a double as uint64."""
    if x != types.float64:
        return None

    def codegen(context, builder, signature, args):
        return builder.bitcast(args[0], ir.IntType(64))

    return types.uint64(types.float64), codegen


@intrinsic
def _double(typingctx, u):
    """The double with bit pattern u (uint64)."""
    if u != types.uint64:
        return None

    def codegen(context, builder, signature, args):
        return builder.bitcast(args[0], ir.DoubleType())

    return types.float64(types.uint64), codegen


@njit(cache=True, error_model="numpy", inline="always")
def expf(x):
    """e^x of a float32 x as a float32, bit-identical to glibc's expf (FMA build)."""
    x = np.float32(x)
    if not (abs(x) < np.float32(88.0)):  # |x| >= 88, inf or NaN: the library's slow path
        if x != x or x == np.float32(np.inf):
            return x + x
        if x == np.float32(-np.inf):
            return np.float32(0.0)
        if x > OVERFLOW:
            return np.float32(np.inf)
        if x < UNDERFLOW:
            return np.float32(0.0)
        if x < MAY_UNDERFLOW:
            return TINY
    xd = np.float64(x)
    kd = _fma(INV_LN2_N, xd, SHIFT)
    ki = _bits(kd)
    kd = kd - SHIFT
    r = _fma(INV_LN2_N, xd, -kd)
    s = _double(TABLE[ki & np.uint64(31)] + (ki << np.uint64(47)))
    z = _fma(r, C0, C1)
    r2 = r * r
    y = _fma(r, C2, 1.0)
    y = _fma(z, r2, y)
    return np.float32(y * s)


@njit(cache=True, error_model="numpy")
def expf_array(x, out):
    """out[i] = expf(x[i]) (for the checks)."""
    for i in range(x.shape[0]):
        out[i] = expf(x[i])


@njit(cache=True, error_model="numpy")
def libm_expf_array(x, out):
    """out[i] = the C library's expf(x[i]) (numba's math.exp of a float32)."""
    for i in range(x.shape[0]):
        out[i] = math.exp(x[i])


@njit(cache=True, error_model="numpy")
def sigmoid_8_array(x, out):
    """out = the network's sigmoid of x through `sigmoid_8`, eight at a time (len(x) a multiple of 8)."""
    zeros = np.zeros(8, dtype=np.float32)
    for i in range(0, x.shape[0], 8):
        sigmoid_8(out, i, x, i, zeros, 0, TABLE)


@njit(cache=True, error_model="numpy")
def libm_sigmoid_array(x, out):
    """out[i] = 1/(1 + e^(-4.9 x[i])) in float32 with the C library's expf (the scalar formula)."""
    for i in range(x.shape[0]):
        out[i] = np.float32(1.0) / (np.float32(1.0) + np.float32(math.exp(-SIGMOID_SLOPE32 * x[i])))


@intrinsic
def sigmoid_8(typingctx, dst, dst_at, src, src_at, bias, bias_at, table):
    """dst[dst_at + i] = 1/(1 + expf(-4.9 (src[src_at + i] + bias[bias_at + i]))) for i = 0..7, float32.

    The network's sigmoid for eight hidden nodes at once: `expf` above, lane by lane in one 8-wide vector
    (the same IEEE operations and fused multiply-adds per lane, the table read per lane), and the special cases
    as selects.  Offsets are in elements of C-contiguous float32 arrays; `table` is TABLE.
    benchmarks/check_expf.py compares it with the scalar sigmoid for every float32 input.
    """
    f32_arrays = all(isinstance(a, types.Array) and a.dtype == types.float32 and a.layout == "C"
                     for a in (dst, src, bias))
    if not (f32_arrays and isinstance(table, types.Array) and table.dtype == types.uint64):
        return None
    sig = types.void(dst, types.intp, src, types.intp, bias, types.intp, table)

    def codegen(context, builder, signature, args):
        vf = ir.VectorType(ir.FloatType(), 8)
        p_dst, p_src, p_bias, p_tab = (context.make_array(signature.args[a])(context, builder, args[a]).data
                                       for a in (0, 2, 4, 6))

        def load8(ptr, at):
            return builder.load(builder.bitcast(builder.gep(ptr, [at], inbounds=True), vf.as_pointer()), align=4)

        x = builder.fadd(load8(p_src, args[3]), load8(p_bias, args[5]))
        out = sigmoid_ir(builder, x, p_tab)
        builder.store(out, builder.bitcast(builder.gep(p_dst, [args[1]], inbounds=True), vf.as_pointer()), align=4)
        return context.get_dummy_value()

    return sig, codegen


@intrinsic
def expf_8(typingctx, buf, at, table):
    """buf[at + i] = expf(buf[at + i]) for i = 0..7, in place, float32: `expf` lane by lane in one 8-wide vector
    (`expf_ir`), for loops over many exponentials (the lean PPO's compiled GRU, baselines/lean/gru_kernel.py).
    `buf` is a C-contiguous float32 array, `table` is TABLE."""
    if not (isinstance(buf, types.Array) and buf.dtype == types.float32 and buf.layout == "C"
            and isinstance(table, types.Array) and table.dtype == types.uint64):
        return None
    sig = types.void(buf, types.intp, table)

    def codegen(context, builder, signature, args):
        vf = ir.VectorType(ir.FloatType(), 8)
        p_buf = context.make_array(signature.args[0])(context, builder, args[0]).data
        p_tab = context.make_array(signature.args[2])(context, builder, args[2]).data
        ptr = builder.bitcast(builder.gep(p_buf, [args[1]], inbounds=True), vf.as_pointer())
        builder.store(expf_ir(builder, builder.load(ptr, align=4), p_tab), ptr, align=4)
        return context.get_dummy_value()

    return sig, codegen


@njit(cache=True, error_model="numpy")
def expf_8_array(x, out):
    """out[i] = expf(x[i]) through `expf_8`, eight at a time (len(x) a multiple of 8; for the checks)."""
    out[:] = x
    for i in range(0, x.shape[0], 8):
        expf_8(out, i, TABLE)


def sigmoid_ir(builder: ir.IRBuilder, x: ir.Value, p_tab: ir.Value) -> ir.Value:
    """LLVM IR of the network's sigmoid 1/(1 + expf(-4.9 x)) for a float32 vector x of any width, lane by lane
    (`expf_ir`).  `p_tab` points to TABLE.  The one vector definition of the sigmoid (`sigmoid_8`, the
    controller's network)."""
    vf = x.type
    e = expf_ir(builder, builder.fmul(ir.Constant(vf, [float(-SIGMOID_SLOPE32)] * vf.count), x), p_tab)
    one = ir.Constant(vf, [1.0] * vf.count)
    return builder.fdiv(one, builder.fadd(one, e))


def expf_ir(builder: ir.IRBuilder, v: ir.Value, p_tab: ir.Value) -> ir.Value:
    """LLVM IR of `expf` for a float32 vector v of any width, lane by lane: the same double-precision IEEE
    operations and fused multiply-adds per lane, the table read per lane, the library's special cases as
    selects.  `p_tab` points to TABLE.  benchmarks/check_expf.py compares it with the library for every
    float32."""
    f32, f64, i64, i32 = ir.FloatType(), ir.DoubleType(), ir.IntType(64), ir.IntType(32)
    width = v.type.count
    vf, vd, vi = ir.VectorType(f32, width), ir.VectorType(f64, width), ir.VectorType(i64, width)

    def splat(ty, value):
        return ir.Constant(ty, [value] * width)

    fma = cgutils.get_or_insert_function(builder.module, ir.FunctionType(vd, [vd, vd, vd]), f"llvm.fma.v{width}f64")
    xd = builder.fpext(v, vd)
    kd = builder.call(fma, [splat(vd, INV_LN2_N), xd, splat(vd, SHIFT)])
    ki = builder.bitcast(kd, vi)
    kd = builder.fsub(kd, splat(vd, SHIFT))
    r = builder.call(fma, [splat(vd, INV_LN2_N), xd, builder.fsub(splat(vd, -0.0), kd)])
    idx = builder.and_(ki, splat(vi, 31))
    # the table read of every lane as one gather (lowered to the CPU's gather instruction where it has one)
    base = builder.insert_element(ir.Constant(vi, ir.Undefined), builder.ptrtoint(p_tab, i64), ir.Constant(i32, 0))
    base = builder.shuffle_vector(base, ir.Constant(vi, ir.Undefined), ir.Constant(ir.VectorType(i32, width),
                                                                                  [0] * width))
    vp = ir.VectorType(p_tab.type, width)
    mask = ir.VectorType(ir.IntType(1), width)
    gather = cgutils.get_or_insert_function(builder.module, ir.FunctionType(vi, [vp, i32, mask, vi]),
                                            f"llvm.masked.gather.v{width}i64.v{width}p0")
    tab = builder.call(gather, [builder.inttoptr(builder.add(base, builder.shl(idx, splat(vi, 3))), vp),
                                ir.Constant(i32, 8), ir.Constant(mask, [1] * width), ir.Constant(vi, ir.Undefined)])
    s = builder.bitcast(builder.add(tab, builder.shl(ki, splat(vi, 47))), vd)
    z = builder.call(fma, [r, splat(vd, C0), splat(vd, C1)])
    r2 = builder.fmul(r, r)
    y = builder.call(fma, [r, splat(vd, C2), splat(vd, 1.0)])
    y = builder.call(fma, [z, r2, y])
    e = builder.fptrunc(builder.fmul(y, s), vf)
    # the library's slow path (|v| >= 88, inf, NaN), as selects; lanes below 88 in magnitude keep e
    e = builder.select(builder.fcmp_ordered("<", v, splat(vf, float(MAY_UNDERFLOW))), splat(vf, float(TINY)), e)
    e = builder.select(builder.fcmp_ordered("<", v, splat(vf, float(UNDERFLOW))), splat(vf, 0.0), e)
    e = builder.select(builder.fcmp_ordered(">", v, splat(vf, float(OVERFLOW))), splat(vf, math.inf), e)
    return builder.select(builder.fcmp_unordered("uno", v, v), builder.fadd(v, v), e)
