"""The original's other CPPN activation: synchronous relaxation, ``MultipleSteps(2 * hidden + 1)``.

The IROS 2011 code decodes the substrate with a depth-first recursive pass (:mod:`.plan`), in which recurrent CPPN
links add 0 and Multiply modules are never evaluated.  Its substrate code still carries the older path as a
comment, ``network.MultipleSteps(iterations)`` with ``iterations = 2 * (TotalNeuronCount - (InputNeuronCount +
OutputNeuronCount)) + 1`` (SharpNeatLib/CPPNs/SubstrateDescription.cs; the activation itself is
SharpNeatLib/NeuralNetwork/ModularNetwork/ModularNetwork.cs, SingleStepInternal).  The paper's runs may have used
it.  One step, for every query, after clearing every signal but the bias (1) and writing the inputs:

1. every connection, in genome connection order, adds ``signal[src] * w`` to its target's new sum (from 0);
2. every non-input node takes ``f(sum)`` (the per-node bias field is 0 in these genomes);
3. every module, in module order, writes the product of its input nodes' new values to its output node;
4. the new values replace the old ones.

So Multiply modules are live and a recurrent CPPN link feeds the previous step's value.  On an acyclic CPPN the
values stop changing after (depth + 1) steps, and then equal the recursive pass with ``evaluate_modules``; we stop
as soon as one step changes nothing (exact: a step is a deterministic function of the signals), which keeps the
cost near the recursive pass except for CPPNs whose cycles keep the signals moving.
"""
from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numba
import numpy as np
from llvmlite import ir
from numba import types
from numba.extending import intrinsic

from mahn_envs.core.expf import TABLE, expf, expf_ir, sigmoid_ir

from .activations import activation_code
from .sinf import LIMIT, sine_lanes_intrinsic

if TYPE_CHECKING:  # pragma: no cover
    from ..neat.genome import Genome

__all__ = ["RelaxPlan", "compile_relax", "relax_population", "relax_steps"]

_F = np.float32


@numba.njit(cache=True, inline="always")
def _activate(code: int, x: np.float32) -> np.float32:
    """The activation functions of :mod:`.activations`, on one float32 (same codes, same float32 formulas)."""
    if code == 0:  # bipolar sigmoid
        return _F(2.0) / (_F(1.0) + expf(_F(-4.9) * x)) - _F(1.0)
    if code == 1:  # gaussian
        y = _F(2.5) * x
        return _F(2.0) * expf(-(y * y)) - _F(1.0)
    if code == 2:
        return abs(x)
    if code == 3:
        return np.float32(math.sin(_F(2.0) * x))
    if code == 4:  # error sign
        if x >= _F(0.0001):
            return _F(1.0)
        if x <= _F(-0.0001):
            return _F(-1.0)
        return _F(0.0)
    if code == 5:
        return x
    if code == 7:  # sigmoid
        return _F(1.0) / (_F(1.0) + expf(_F(-4.9) * x))
    return _F(0.0)  # zero / null: a module output before its module writes it


#: Queries relaxed side by side: a block's signals are a (nodes, LANES) float32 array, so each connection and each
#: activation is a loop over contiguous lanes that the compiler vectorises.
LANES = 64


def _exp_lanes(kind: str):
    """An intrinsic f(new, at, table) that applies activation `kind` to the LANES float32 values new[at:at+LANES]
    (element offset in the C-contiguous array) as one vector: the operations of `_activate` for that code, in
    its order, with `expf` as `expf_ir` (the same IEEE operations per lane), so every lane is bit-identical to
    the scalar loop.  The compiler cannot vectorise the scalar expf (its special cases branch), and these
    activations are most of the relaxation's time."""

    def impl(typingctx, new, at, table):
        if not (isinstance(new, types.Array) and new.dtype == types.float32 and new.layout == "C"
                and isinstance(table, types.Array) and table.dtype == types.uint64):
            return None

        def codegen(context, builder, signature, args):
            vf = ir.VectorType(ir.FloatType(), LANES)
            p_new = context.make_array(signature.args[0])(context, builder, args[0]).data
            p_tab = context.make_array(signature.args[2])(context, builder, args[2]).data
            ptr = builder.bitcast(builder.gep(p_new, [args[1]], inbounds=True), vf.as_pointer())
            x = builder.load(ptr, align=4)

            def splat(value):
                return ir.Constant(vf, [value] * LANES)

            if kind == "bipolar":  # 2 / (1 + expf(-4.9 x)) - 1
                e = expf_ir(builder, builder.fmul(splat(float(_F(-4.9))), x), p_tab)
                y = builder.fsub(builder.fdiv(splat(2.0), builder.fadd(splat(1.0), e)), splat(1.0))
            elif kind == "gaussian":  # 2 expf(-(2.5 x)^2) - 1
                z = builder.fmul(splat(2.5), x)
                e = expf_ir(builder, builder.fneg(builder.fmul(z, z)), p_tab)
                y = builder.fsub(builder.fmul(splat(2.0), e), splat(1.0))
            else:  # sigmoid: 1 / (1 + expf(-4.9 x))
                y = sigmoid_ir(builder, x, p_tab)
            builder.store(y, ptr, align=4)
            return context.get_dummy_value()

        return types.void(new, types.intp, table), codegen

    impl.__name__ = f"_{kind}_lanes"
    return intrinsic(impl)


_bipolar_lanes = _exp_lanes("bipolar")
_gaussian_lanes = _exp_lanes("gaussian")
_sigmoid_lanes = _exp_lanes("sigmoid")
_sine_lanes = sine_lanes_intrinsic(LANES)
_SINE_LIMIT = np.float32(LIMIT)


@numba.njit(cache=True, inline="always")
def _sine_row(new, i):  # pragma: no cover
    """Activation code 3, sin(2x), on row i: as one vector (`sinf.sin2x_ir`) when every argument is in its range,
    else through the library lane by lane (the same values either way)."""
    inside = True
    for k in range(LANES):
        if not (abs(_F(2.0) * new[i, k]) < _SINE_LIMIT):
            inside = False
    if inside:
        _sine_lanes(new, i * LANES)
    else:
        for k in range(LANES):
            new[i, k] = _activate(3, new[i, k])


@numba.njit(cache=True, inline="always")
def activate_row(new, i, code):  # pragma: no cover
    """Activation `code` on the LANES values of row i of a block, in place: the exponential ones and the sine as
    vectors (the same values as `_activate`, see `_exp_lanes` and `_sine_row`), the others lane by lane."""
    if code == 0:
        _bipolar_lanes(new, i * LANES, TABLE)
    elif code == 1:
        _gaussian_lanes(new, i * LANES, TABLE)
    elif code == 7:
        _sigmoid_lanes(new, i * LANES, TABLE)
    elif code == 3:
        _sine_row(new, i)
    else:
        for k in range(LANES):
            new[i, k] = _activate(code, new[i, k])


@numba.njit(cache=True, inline="always")
def _relax_into(queries, n_in, act, csrc, cdst, cw, mod_ptr, mod_in, mod_out, out_idx, steps, out):  # pragma: no cover
    """Relax every query of one genome into out (Q, n_outputs); queries run in blocks of LANES side by side.

    Each query sees exactly the float32 operations of a one-query loop, in the same order (connections in genome
    order into a zeroed sum, then the activations, then the modules), so the result is bit for bit the same.  A
    block stops when every lane has stopped changing; a lane that reached its fixed point earlier stays on it
    (one more step from a fixed point changes nothing), so stopping later does not change its values.
    """
    n_q = queries.shape[0]
    n = act.shape[0]
    sig = np.empty((n, LANES), dtype=np.float32)
    new = np.empty((n, LANES), dtype=np.float32)
    first = n_in + 1
    for q0 in range(0, n_q, LANES):
        w = min(LANES, n_q - q0)
        sig[:, :] = 0.0
        for k in range(w):
            sig[0, k] = 1.0
            for j in range(n_in):
                sig[1 + j, k] = queries[q0 + k, j]
        for _ in range(steps):
            for i in range(first, n):
                for k in range(LANES):
                    new[i, k] = 0.0
            for c in range(csrc.shape[0]):
                s = csrc[c]
                d = cdst[c]
                wc = cw[c]
                for k in range(LANES):
                    new[d, k] += sig[s, k] * wc
            for i in range(first, n):
                activate_row(new, i, act[i])
            for m in range(mod_ptr.shape[0] - 1):
                o = mod_out[m]
                for k in range(LANES):
                    prod = np.float32(1.0)
                    for t in range(mod_ptr[m], mod_ptr[m + 1]):
                        prod *= new[mod_in[t], k]
                    new[o, k] = prod
            same = True
            for i in range(first, n):
                for k in range(w):
                    if new[i, k] != sig[i, k]:
                        same = False
                for k in range(LANES):
                    sig[i, k] = new[i, k]
            if same:
                break
        for k in range(w):
            for o in range(out_idx.shape[0]):
                out[q0 + k, o] = sig[out_idx[o], k]


@numba.njit(cache=True)
def _relax(queries, n_in, act, csrc, cdst, cw, mod_ptr, mod_in, mod_out, out_idx, steps):  # pragma: no cover
    """One genome's outputs (Q, n_outputs) at the queries (`_relax_into`)."""
    out = np.empty((queries.shape[0], out_idx.shape[0]), dtype=np.float32)
    _relax_into(queries, n_in, act, csrc, cdst, cw, mod_ptr, mod_in, mod_out, out_idx, steps, out)
    return out


@numba.njit(cache=True, parallel=True)
def _relax_many(queries, n_in, node_ptr, act, conn_ptr, csrc, cdst, cw, mptr_ptr, mod_ptr, min_ptr, mod_in,
                mod_out, out_idx, steps, out):  # pragma: no cover
    """Every genome of a population at the same queries, genomes spread over the cores: genome g's arrays are
    the slices [ptr[g], ptr[g + 1]) of the concatenated ones, and its outputs go to out[g].  Each genome runs
    `_relax_into` exactly as alone, so the outputs are bit for bit those of one `_relax` call per genome."""
    for g in numba.prange(out.shape[0]):
        m0 = mptr_ptr[g]
        m1 = mptr_ptr[g + 1]
        _relax_into(queries, n_in, act[node_ptr[g]:node_ptr[g + 1]], csrc[conn_ptr[g]:conn_ptr[g + 1]],
                    cdst[conn_ptr[g]:conn_ptr[g + 1]], cw[conn_ptr[g]:conn_ptr[g + 1]], mod_ptr[m0:m1],
                    mod_in[min_ptr[g]:min_ptr[g + 1]], mod_out[m0 - g:m1 - g - 1], out_idx[g], steps[g], out[g])


def relax_population(plans: Sequence[RelaxPlan], inputs: np.ndarray) -> np.ndarray:
    """Outputs (N, Q, n_outputs), float32, of N relaxation plans at the same inputs (Q, n_inputs): bit for bit
    np.stack of each plan's `evaluate(inputs)`, with the genomes spread over the cores (decoding a late
    population of grown CPPNs is most of a generation's time with this activation)."""
    if not plans:
        raise ValueError("relax_population: no plans to evaluate")
    x = np.ascontiguousarray(inputs, dtype=np.float32)
    n_in, n_out = plans[0].n_inputs, plans[0].n_outputs
    if x.ndim != 2 or x.shape[1] != n_in:
        raise ValueError(f"relax_population: expected inputs of shape (Q, {n_in}), got {x.shape}")
    if any(p.n_inputs != n_in or p.n_outputs != n_out for p in plans):
        raise ValueError("relax_population: every plan must have the same numbers of inputs and outputs")

    def ptr(sizes) -> np.ndarray:
        return np.concatenate([[0], np.cumsum(np.fromiter(sizes, dtype=np.int64, count=len(plans)))])

    def cat(name: str, dtype: type) -> np.ndarray:
        return np.concatenate([getattr(p, name) for p in plans]).astype(dtype, copy=False)

    out = np.empty((len(plans), x.shape[0], n_out), dtype=np.float32)
    _relax_many(x, n_in, ptr(p.act.size for p in plans), cat("act", np.int64), ptr(p.src.size for p in plans),
                cat("src", np.int64), cat("dst", np.int64), cat("weight", np.float32),
                ptr(p.mod_ptr.size for p in plans), cat("mod_ptr", np.int64), ptr(p.mod_in.size for p in plans),
                cat("mod_in", np.int64), cat("mod_out", np.int64),
                np.stack([p.output_idx for p in plans]).astype(np.int64),
                np.fromiter((p.steps for p in plans), dtype=np.int64, count=len(plans)), out)
    return out


def relax_steps(n_nodes: int, n_inputs: int, n_outputs: int) -> int:
    """The original's step count: 2 * (all neurons, the bias included, minus inputs and outputs) + 1."""
    return 2 * (n_nodes - (n_inputs + n_outputs)) + 1


@dataclass(frozen=True)
class RelaxPlan:
    """A genome flattened for :func:`_relax`: node 0 the bias, 1..n_inputs the inputs, then the other nodes."""

    n_inputs: int
    act: np.ndarray  # activation code per node
    src: np.ndarray  # connection source node index, genome connection order
    dst: np.ndarray
    weight: np.ndarray  # float32
    mod_ptr: np.ndarray  # module k reads mod_in[mod_ptr[k]:mod_ptr[k+1]] ...
    mod_in: np.ndarray
    mod_out: np.ndarray  # ... and writes node mod_out[k]
    output_idx: np.ndarray
    steps: int

    @property
    def n_outputs(self) -> int:
        return int(self.output_idx.size)

    def evaluate(self, inputs: np.ndarray, dtype: type = np.float32) -> np.ndarray:
        """Outputs (Q, n_outputs) for inputs (Q, n_inputs), as :meth:`CppnPlan.evaluate` (float32 only)."""
        if dtype is not np.float32:
            raise ValueError("the relaxation activation runs in float32 only, as the original")
        x = np.ascontiguousarray(inputs, dtype=np.float32)
        if x.ndim == 1:
            x = x[None, :]
        if x.ndim != 2 or x.shape[1] != self.n_inputs:
            raise ValueError(f"RelaxPlan.evaluate: expected inputs of shape (Q, {self.n_inputs}), got {x.shape}")
        return _relax(x, self.n_inputs, self.act, self.src, self.dst, self.weight, self.mod_ptr, self.mod_in,
                      self.mod_out, self.output_idx, self.steps)


def compile_relax(genome: Genome) -> RelaxPlan:
    """Index a genome's nodes (bias, inputs in id order, then the rest in genome order) for :func:`_relax`."""
    bias = [n.id for n in genome.nodes if n.kind == "bias"]
    if len(bias) != 1:
        raise ValueError(f"compile_relax: a CPPN genome has exactly one bias node, got {len(bias)}")
    inputs = list(genome.input_ids)
    rest = [n for n in genome.nodes if n.kind not in ("bias", "input")]
    order = bias + inputs + [n.id for n in rest]
    index = {nid: k for k, nid in enumerate(order)}
    act = np.zeros(len(order), dtype=np.int64)
    for n in rest:
        act[index[n.id]] = activation_code("zero" if n.kind == "module_out" else n.activation)
    mod_ptr: list[int] = [0]
    mod_in: list[int] = []
    mod_out: list[int] = []
    for m in genome.modules:
        if m.function != "multiply" or len(m.outputs) != 1:
            raise ValueError(f"compile_relax: only one-output Multiply modules are known, got {m}")
        mod_in.extend(index[i] for i in m.inputs)
        mod_ptr.append(len(mod_in))
        mod_out.append(index[m.outputs[0]])
    outputs = list(genome.output_ids)
    return RelaxPlan(
        n_inputs=len(inputs),
        act=act,
        src=np.array([index[s] for s in genome.src.tolist()], dtype=np.int64),
        dst=np.array([index[d] for d in genome.dst.tolist()], dtype=np.int64),
        weight=np.asarray(genome.weight, dtype=np.float32),
        mod_ptr=np.asarray(mod_ptr, dtype=np.int64),
        mod_in=np.asarray(mod_in, dtype=np.int64),
        mod_out=np.asarray(mod_out, dtype=np.int64),
        output_idx=np.array([index[o] for o in outputs], dtype=np.int64),
        steps=relax_steps(len(order), len(inputs), len(outputs)),
    )
