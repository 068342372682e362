"""Ray casts and wall contacts, compiled.  The one place the task's geometry is computed.

The tests compare these kernels against brute-force references (tests/envs/test_geometry.py); the parameter
tests below use the original simulator's strict inequalities so sensor readings match it exactly.
"""
from __future__ import annotations

import math

import numpy as np
from llvmlite import ir
from numba import njit, types
from numba.core import cgutils
from numba.extending import intrinsic

#: rays cast side by side in `_nearest_walls_8` (the Khepera III has 6)
RAY_LANES = 8


def wall_boxes(walls: np.ndarray) -> np.ndarray:
    """Axis-aligned boxes (xmin, ymin, xmax, ymax) of the walls, used to skip walls out of sensor reach."""
    w = np.asarray(walls, dtype=np.float64)
    return np.stack([np.minimum(w[:, 0], w[:, 2]), np.minimum(w[:, 1], w[:, 3]),
                     np.maximum(w[:, 0], w[:, 2]), np.maximum(w[:, 1], w[:, 3])], axis=1)


def sensor_directions(angles) -> np.ndarray:
    """(cos a, sin a) of each sensor's angle relative to the heading, computed once per simulator."""
    a = np.asarray(angles, dtype=np.float64)
    return np.ascontiguousarray(np.stack([np.cos(a), np.sin(a)], axis=1))


@njit(cache=True, error_model="numpy", inline="always")
def ray_wall(cx, cy, dx, dy, x1, y1, x2, y2):
    """Fraction along the ray (c, c + d) where it crosses the wall, or 2.0 for no hit.

    Strict 0 < r < 1 and 0 < s < 1, parallel segments never hit: the original's test.
    """
    ex = x2 - x1
    ey = y2 - y1
    denom = dx * ey - dy * ex
    if denom == 0.0:
        return 2.0
    ax = x1 - cx
    ay = y1 - cy
    r = (ax * ey - ay * ex) / denom
    s = (ax * dy - ay * dx) / denom
    if 0.0 < r < 1.0 and 0.0 < s < 1.0:
        return r
    return 2.0


@njit(cache=True, error_model="numpy", inline="always")
def ray_circle(cx, cy, ux, uy, qx, qy, radius):
    """Distance along the unit ray u from c to the first crossing of the circle (q, radius); inf if none."""
    px = qx - cx
    py = qy - cy
    b = ux * px + uy * py
    c = px * px + py * py - radius * radius
    if c <= 0.0:  # the ray starts inside the circle (overlapping robots): no reading from it
        return math.inf
    disc = b * b - c
    if disc < 0.0 or b <= 0.0:
        return math.inf
    return b - math.sqrt(disc)


@njit(cache=True, error_model="numpy", inline="always")
def touches_wall(cx, cy, radius, x1, y1, x2, y2):
    """True when a circle at c is closer than `radius` to the wall: projection test, then endpoints."""
    ex = x2 - x1
    ey = y2 - y1
    len2 = ex * ex + ey * ey
    r = ((cx - x1) * ex + (cy - y1) * ey) / len2
    if 0.0 <= r <= 1.0:
        cross = (cx - x1) * ey - (cy - y1) * ex
        return abs(cross) / math.sqrt(len2) < radius
    d1 = (cx - x1) * (cx - x1) + (cy - y1) * (cy - y1)
    d2 = (cx - x2) * (cx - x2) + (cy - y2) * (cy - y2)
    return d1 < radius * radius or d2 < radius * radius


@njit(cache=True, error_model="numpy", inline="always")
def touches_any_wall(cx, cy, radius, walls, boxes):
    for w in range(walls.shape[0]):
        if (cx + radius < boxes[w, 0] or cx - radius > boxes[w, 2]
                or cy + radius < boxes[w, 1] or cy - radius > boxes[w, 3]):
            continue
        if touches_wall(cx, cy, radius, walls[w, 0], walls[w, 1], walls[w, 2], walls[w, 3]):
            return True
    return False


def _is_array(a, dtype, ndim: int) -> bool:
    return isinstance(a, types.Array) and a.dtype == dtype and a.ndim == ndim


@intrinsic
def _nearest_walls_8(typingctx, out, n_rays, dirs, ch, sh, max_range, cx, cy, walls, cand, n_cand):
    """`_nearest_walls` for up to 8 rays, the rays side by side in one 8-lane float64 vector.

    Per candidate wall every ray runs the scalar loop's operations (the same multiplies, subtractions and
    divisions of the same numbers; IEEE vector arithmetic is lane-wise and, without fast-math, LLVM neither
    fuses nor reorders them) and its tests become lane masks: a lane takes the new distance exactly when the
    scalar loop would (the pre-test on the numerators, then 0 < r < 1, 0 < s < 1 and d < the nearest so far).
    So readings are bit-identical, without the scalar loop's six data-dependent branches per wall.  Lanes
    beyond n_rays repeat ray 0 and are never stored.
    """
    f8 = types.float64
    if not (_is_array(out, f8, 1) and _is_array(dirs, f8, 2) and _is_array(walls, f8, 2)
            and _is_array(cand, types.int64, 1)):
        return None
    sig = types.void(out, types.intp, dirs, f8, f8, f8, f8, f8, walls, cand, types.intp)

    def codegen(context, builder, signature, args):
        f64, i32 = ir.DoubleType(), ir.IntType(32)
        intp = context.get_value_type(types.intp)
        vd = ir.VectorType(f64, RAY_LANES)
        a_out, a_dirs, a_walls, a_cand = (context.make_array(signature.args[a])(context, builder, args[a])
                                          for a in (0, 2, 8, 9))
        n, ch, sh, max_range, cx, cy, n_cand = (args[a] for a in (1, 3, 4, 5, 6, 7, 10))

        def load(ty, ary, *idx):
            return builder.load(cgutils.get_item_pointer(context, builder, ty, ary, list(idx)))

        def const(i):
            return ir.Constant(intp, i)

        def splat(x):
            v = builder.insert_element(ir.Constant(vd, ir.Undefined), x, ir.Constant(i32, 0))
            return builder.shuffle_vector(v, ir.Constant(vd, ir.Undefined),
                                          ir.Constant(ir.VectorType(i32, RAY_LANES), [0] * RAY_LANES))

        t_out, t_dirs, t_walls, t_cand = (signature.args[a] for a in (0, 2, 8, 9))
        c0 = s0 = ir.Constant(vd, ir.Undefined)
        for j in range(RAY_LANES):
            jj = builder.select(builder.icmp_signed("<", const(j), n), const(j), const(0))
            c0 = builder.insert_element(c0, load(t_dirs, a_dirs, jj, const(0)), ir.Constant(i32, j))
            s0 = builder.insert_element(s0, load(t_dirs, a_dirs, jj, const(1)), ir.Constant(i32, j))
        vch, vsh, vrange = splat(ch), splat(sh), splat(max_range)
        ux = builder.fsub(builder.fmul(vch, c0), builder.fmul(vsh, s0))
        uy = builder.fadd(builder.fmul(vsh, c0), builder.fmul(vch, s0))
        dx = builder.fmul(ux, vrange)
        dy = builder.fmul(uy, vrange)
        zero, one = splat(ir.Constant(f64, 0.0)), splat(ir.Constant(f64, 1.0))
        best = cgutils.alloca_once_value(builder, vrange)
        with cgutils.for_range(builder, n_cand) as loop:
            w = load(t_cand, a_cand, loop.index)
            x1 = load(t_walls, a_walls, w, const(0))
            y1 = load(t_walls, a_walls, w, const(1))
            ex = builder.fsub(load(t_walls, a_walls, w, const(2)), x1)
            ey = builder.fsub(load(t_walls, a_walls, w, const(3)), y1)
            ax = builder.fsub(x1, cx)
            ay = builder.fsub(y1, cy)
            rn = splat(builder.fsub(builder.fmul(ax, ey), builder.fmul(ay, ex)))
            denom = builder.fsub(builder.fmul(dx, splat(ey)), builder.fmul(dy, splat(ex)))
            sn = builder.fsub(builder.fmul(splat(ax), dy), builder.fmul(splat(ay), dx))

            def lt(a, b):
                return builder.fcmp_ordered("<", a, b)

            pre_pos = builder.and_(builder.and_(lt(zero, rn), lt(rn, denom)), builder.and_(lt(zero, sn), lt(sn, denom)))
            pre_neg = builder.and_(builder.and_(lt(denom, rn), lt(rn, zero)), builder.and_(lt(denom, sn), lt(sn, zero)))
            pre = builder.select(lt(zero, denom), pre_pos, pre_neg)
            r = builder.fdiv(rn, denom)
            s = builder.fdiv(sn, denom)
            hit = builder.and_(pre, builder.and_(builder.and_(lt(zero, r), lt(r, one)),
                                                 builder.and_(lt(zero, s), lt(s, one))))
            d = builder.fmul(r, vrange)
            old = builder.load(best)
            builder.store(builder.select(builder.and_(hit, lt(d, old)), d, old), best)
        near = builder.load(best)
        for j in range(RAY_LANES):
            with builder.if_then(builder.icmp_signed("<", const(j), n)):
                builder.store(builder.extract_element(near, ir.Constant(i32, j)),
                              cgutils.get_item_pointer(context, builder, t_out, a_out, [const(j)]))
        return context.get_dummy_value()

    return sig, codegen


@njit(cache=True, error_model="numpy", inline="always")
def _nearest_walls(out, n_rays, dirs, ch, sh, max_range, cx, cy, walls, cand, n_cand):
    """out[j] = distance to the nearest of the candidate walls along ray j (max_range if none), one ray at a time.

    Walls outer, rays inner: the ray-independent half of `ray_wall` (the wall's direction, its offset from
    the centre and the numerator of r) is computed once per wall.  Each ray still meets the walls in the
    same order with the same arithmetic, so readings are bit-identical to `ray_wall` over rays then walls.
    """
    for j in range(n_rays):
        out[j] = max_range
    for k in range(n_cand):
        w = cand[k]
        x1 = walls[w, 0]
        y1 = walls[w, 1]
        ex = walls[w, 2] - x1
        ey = walls[w, 3] - y1
        ax = x1 - cx
        ay = y1 - cy
        rn = ax * ey - ay * ex
        for j in range(n_rays):
            # rotate the precomputed sensor direction by the heading: one sincos per robot, not one per ray
            ux = ch * dirs[j, 0] - sh * dirs[j, 1]
            uy = sh * dirs[j, 0] + ch * dirs[j, 1]
            dx = ux * max_range
            dy = uy * max_range
            denom = dx * ey - dy * ex
            if denom == 0.0:
                continue
            sn = ax * dy - ay * dx
            # r = rn / denom and s = sn / denom must both lie strictly in (0, 1).  Rounding a quotient is
            # monotonic, so numerators outside (0, denom) (or (denom, 0)) are certain misses: skip the two
            # divisions.  Anything else goes through the exact test of `ray_wall`.
            if denom > 0.0:
                if not (0.0 < rn < denom and 0.0 < sn < denom):
                    continue
            elif not (denom < rn < 0.0 and denom < sn < 0.0):
                continue
            r = rn / denom
            s = sn / denom
            if 0.0 < r < 1.0 and 0.0 < s < 1.0:
                d = r * max_range
                if d < out[j]:
                    out[j] = d


@njit(cache=True, error_model="numpy", inline="always")
def cast_rays(cx, cy, heading, dirs, max_range, walls, boxes, others, n_others, robot_radius, out, cand):
    """Centre-to-hit distance of each ray (max_range when nothing is hit) against walls and other robots.

    `dirs` holds (cos a, sin a) of each sensor angle a (see `sensor_directions`).
    `others` holds (x, y) of robots that can be seen; only the first n_others rows are used.  `cand` is an
    int scratch array of at least len(walls) entries (passed in so the hot loop never allocates).
    """
    cast_rays_trig(cx, cy, math.cos(heading), math.sin(heading), dirs, max_range, walls, boxes, others, n_others,
                   robot_radius, out, cand)


@njit(cache=True, error_model="numpy", inline="always")
def cast_rays_trig(cx, cy, ch, sh, dirs, max_range, walls, boxes, others, n_others, robot_radius, out, cand):
    """`cast_rays` given ch = cos(heading) and sh = sin(heading): the episode loop computes them once per tick
    for motion and sensing together."""
    n_rays = dirs.shape[0]
    xmin = cx - max_range
    xmax = cx + max_range
    ymin = cy - max_range
    ymax = cy + max_range
    n_cand = 0
    for w in range(walls.shape[0]):
        if boxes[w, 2] < xmin or boxes[w, 0] > xmax or boxes[w, 3] < ymin or boxes[w, 1] > ymax:
            continue
        cand[n_cand] = w
        n_cand += 1
    if n_rays <= RAY_LANES:
        _nearest_walls_8(out, n_rays, dirs, ch, sh, max_range, cx, cy, walls, cand, n_cand)
    else:
        _nearest_walls(out, n_rays, dirs, ch, sh, max_range, cx, cy, walls, cand, n_cand)
    for j in range(n_rays):
        ux = ch * dirs[j, 0] - sh * dirs[j, 1]
        uy = sh * dirs[j, 0] + ch * dirs[j, 1]
        best = out[j]
        for k in range(n_others):
            qx = others[k, 0]
            qy = others[k, 1]
            if abs(qx - cx) > max_range + robot_radius or abs(qy - cy) > max_range + robot_radius:
                continue
            d = ray_circle(cx, cy, ux, uy, qx, qy, robot_radius)
            if d < best:
                best = d
        out[j] = best
