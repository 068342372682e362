"""The CPPN's sine activation, sin(2x) in float32, as a vector of lanes with exactly the C library's operations.

Why: in the relaxation decode (:mod:`.relax`) about half of the time of a late generation's CPPNs went to the C
library's ``sinf`` (one call per node, query and step; the compiler cannot vectorise a call).  Decoding must stay
bit-identical (a run reproduces from its seed only while every number stays the same), so this is glibc's
algorithm (sysdeps/ieee754/flt-32/s_sinf.c with sincosf.h, the build for CPUs with fused multiply-add that this
machine's libm selects, ``__sinf_fma``), operation for operation, with the fused operations where that build has
them; the constants are those of its table (``__sincosf_table``: sincosf_data.c).  It covers |2x| < 120, where
the library reduces the argument with one fused multiply-add; larger or non-finite arguments (rare: CPPN sums
beyond +-60) take the library's scalar path in the caller.  benchmarks/check_expf.py compares it with the library
for every float32 below 120 in magnitude; the tests compare millions.
"""
from __future__ import annotations

from llvmlite import ir
from numba import types
from numba.core import cgutils
from numba.extending import intrinsic

#: the arguments this vector path takes: |sin argument| below this; the caller runs the others through the library
LIMIT = 120.0

HPI_INV = float.fromhex("0x1.45f306dc9c883p+23")  # 2/pi * 2^24
HPI = float.fromhex("0x1.921fb54442d18p+0")  # pi/2
S1 = float.fromhex("-0x1.555545995a603p-3")
S2 = float.fromhex("0x1.1107605230bc4p-7")
S3 = float.fromhex("-0x1.994eb3774cf24p-13")
#: the cosine polynomial of quadrants 0 and 1; quadrants 2 and 3 use the negated coefficients
C = tuple(float.fromhex(h) for h in ("0x1p+0", "-0x1.ffffffd0c621cp-2", "0x1.55553e1068f19p-5",
                                       "-0x1.6c087e89a359dp-10", "0x1.99343027bf8c3p-16"))
ABSTOP_PIO4 = 0x3F4  # top 12 bits (sign cleared) of pi/4 as a float32: below it, no reduction
ABSTOP_TINY = 0x398  # of 2^-12: below it, sin(y) = y


def sin2x_ir(builder: ir.IRBuilder, x: ir.Value) -> ir.Value:
    """LLVM IR of float32(sinf(2 x)) for a float32 vector x whose |2 x| < LIMIT, lane by lane as ``__sinf_fma``."""
    width = x.type.count
    f32, f64, i32 = ir.FloatType(), ir.DoubleType(), ir.IntType(32)
    vf, vd, vi = ir.VectorType(f32, width), ir.VectorType(f64, width), ir.VectorType(i32, width)
    fma = cgutils.get_or_insert_function(builder.module, ir.FunctionType(vd, [vd, vd, vd]), f"llvm.fma.v{width}f64")

    def d(value):
        return ir.Constant(vd, [value] * width)

    def i(value):
        return ir.Constant(vi, [value] * width)

    y = builder.fmul(ir.Constant(vf, [2.0] * width), x)
    top = builder.and_(builder.lshr(builder.bitcast(y, vi), i(20)), i(0x7FF))
    xd = builder.fpext(y, vd)
    unreduced = builder.icmp_unsigned("<", top, i(ABSTOP_PIO4))
    # reduce_fast: n = round(x * 2/pi) through the 2^24-scaled product, r = x - n * pi/2 in one fused operation
    n = builder.ashr(builder.add(builder.fptosi(builder.fmul(xd, d(HPI_INV)), vi), i(0x800000)), i(24))
    n = builder.select(unreduced, i(0), n)
    r = builder.call(fma, [builder.fneg(builder.sitofp(n, vd)), d(HPI), xd])  # = xd exactly when n = 0
    r2 = builder.fmul(r, r)
    quadrant = builder.and_(n, i(3))
    negative = builder.or_(builder.icmp_unsigned("==", quadrant, i(1)), builder.icmp_unsigned("==", quadrant, i(2)))
    xs = builder.fmul(r, builder.select(negative, d(-1.0), d(1.0)))
    # sine polynomial (even n)
    s = builder.call(fma, [r2, d(S3), d(S2)])
    x3 = builder.fmul(r2, xs)
    x7 = builder.fmul(x3, r2)
    sine = builder.call(fma, [s, x7, builder.call(fma, [x3, d(S1), xs])])
    # cosine polynomial (odd n), negated coefficients in quadrants 2 and 3
    upper = builder.icmp_unsigned("!=", builder.and_(n, i(2)), i(0))
    c = [builder.select(upper, d(-k), d(k)) for k in C]
    x4 = builder.fmul(r2, r2)
    c1 = builder.call(fma, [r2, c[1], c[0]])
    c2 = builder.call(fma, [r2, c[4], c[3]])
    x6 = builder.fmul(r2, x4)
    cosine = builder.call(fma, [c2, x6, builder.call(fma, [x4, c[2], c1])])
    odd = builder.icmp_unsigned("!=", builder.and_(n, i(1)), i(0))
    out = builder.fptrunc(builder.select(odd, cosine, sine), vf)
    return builder.select(builder.icmp_unsigned("<", top, i(ABSTOP_TINY)), y, out)


def sine_lanes_intrinsic(lanes: int):
    """An intrinsic f(new, at) that replaces the `lanes` float32 values new[at:at+lanes] (element offset in the
    C-contiguous array) by float32(sinf(2 x)); every |2 x| must be below LIMIT."""

    def impl(typingctx, new, at):
        if not (isinstance(new, types.Array) and new.dtype == types.float32 and new.layout == "C"):
            return None

        def codegen(context, builder, signature, args):
            vf = ir.VectorType(ir.FloatType(), lanes)
            p_new = context.make_array(signature.args[0])(context, builder, args[0]).data
            ptr = builder.bitcast(builder.gep(p_new, [args[1]], inbounds=True), vf.as_pointer())
            builder.store(sin2x_ir(builder, builder.load(ptr, align=4)), ptr, align=4)
            return context.get_dummy_value()

        return types.void(new, types.intp), codegen

    impl.__name__ = f"_sine_lanes_{lanes}"
    return intrinsic(impl)
