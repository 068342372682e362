"""A whole population's CPPN plans evaluated together: the same numbers as `CppnPlan.evaluate`, far fewer calls.

A generation decodes hundreds of small CPPNs (typically ten nodes) at the same ~1,000 substrate queries.  One
`CppnPlan.evaluate` per genome spends its time in numpy call overhead.  Here op k of every genome runs in "wave" k
(a genome's ops are in evaluation order, so an op only reads the bias, the inputs and earlier ops of its genome):
the weighted sums of a wave are one compiled call, and each activation function is applied once per wave to all
of that wave's ops that use it, through the same numpy functions (`activations.BY_CODE`) as the single-genome
path.  Sums keep every term's float32 multiply and add in the plan's order (no fused multiply-add), and the
activations are the same elementwise ufuncs, so the outputs are bit-identical to evaluating plan by plan (the
tests compare them).  Plans of another kind (a plan class with other fields, another activation scheme) are
evaluated one by one with their own `evaluate`.
"""
from __future__ import annotations

import dataclasses
from collections.abc import Sequence

import numpy as np
from numba import njit

from .activations import BY_CODE
from .plan import MODE_PRODUCT, MODE_SUM, CppnPlan
from .relax import RelaxPlan, relax_population

#: the plan layout this module understands; any other plan falls back to its own evaluate()
_PLAN_FIELDS = ("n_inputs", "node_ids", "op_act", "op_mode", "term_ptr", "term_src", "term_weight", "output_slots")


def _batchable(plans: Sequence) -> bool:
    if not plans or tuple(f.name for f in dataclasses.fields(CppnPlan)) != _PLAN_FIELDS:
        return False
    if not all(type(p) is CppnPlan for p in plans):  # e.g. relaxation plans: evaluated one by one
        return False
    n_in, n_out = plans[0].n_inputs, plans[0].output_slots.size
    return all(type(p) is CppnPlan and p.n_inputs == n_in and p.output_slots.size == n_out for p in plans)


@njit(cache=True, error_model="numpy")
def _wave_sums(v, lo, hi, term_ptr, term_src, term_w, op_mode, out):
    """Rows out[o - lo] for ops lo..hi-1: the weighted sum (MODE_SUM) or product (MODE_PRODUCT) of their terms."""
    n_q = v.shape[1]
    for o in range(lo, hi):
        a = term_ptr[o]
        b = term_ptr[o + 1]
        row = o - lo
        if op_mode[o] == 0:  # MODE_SUM: w0 * s0, then + w * s term by term, all float32
            if a == b:
                for q in range(n_q):
                    out[row, q] = np.float32(0.0)
            else:
                s = term_src[a]
                w = term_w[a]
                for q in range(n_q):
                    out[row, q] = w * v[s, q]
                for t in range(a + 1, b):
                    s = term_src[t]
                    w = term_w[t]
                    for q in range(n_q):
                        out[row, q] = out[row, q] + w * v[s, q]
        else:  # MODE_PRODUCT: 1 * s * s ... (module outputs with evaluate_modules)
            for q in range(n_q):
                out[row, q] = np.float32(1.0)
            for t in range(a, b):
                s = term_src[t]
                for q in range(n_q):
                    out[row, q] = out[row, q] * v[s, q]


#: genomes evaluated together: enough to amortise the calls, few enough that the signals stay in cache
BLOCK = 128


def evaluate_plans(plans: Sequence, inputs: np.ndarray) -> np.ndarray:
    """Outputs (N, Q, n_outputs), float32, of N plans at the same inputs (Q, n_inputs): np.stack of each
    plan's `evaluate(inputs)`, computed wave by wave, BLOCK genomes at a time."""
    if plans and all(type(p) is RelaxPlan for p in plans):  # the relaxation: genomes spread over the cores
        return relax_population(plans, inputs)
    if not _batchable(plans):
        return np.stack([p.evaluate(inputs) for p in plans])
    if len(plans) > BLOCK:
        return np.concatenate([_evaluate_block(plans[i:i + BLOCK], inputs) for i in range(0, len(plans), BLOCK)])
    return _evaluate_block(plans, inputs)


def _evaluate_block(plans: Sequence, inputs: np.ndarray) -> np.ndarray:
    x = np.asarray(inputs, dtype=np.float32)
    n_in = plans[0].n_inputs
    if x.ndim != 2 or x.shape[1] != n_in:
        raise ValueError(f"evaluate_plans: expected inputs of shape (Q, {n_in}), got {x.shape}")
    n_q = x.shape[0]
    first = n_in + 2  # shared slots: bias, inputs, the constant 0; then each genome's ops
    acts = [p.op_act for p in plans]
    modes = np.concatenate([p.op_mode for p in plans])
    if np.any((modes != MODE_SUM) & (modes != MODE_PRODUCT)):
        return np.stack([p.evaluate(inputs) for p in plans])
    n_ops = np.fromiter((a.size for a in acts), dtype=np.int64, count=len(plans))
    ptrs = np.concatenate([p.term_ptr for p in plans]).astype(np.int64)
    gaps = np.cumsum(n_ops + 1)[:-1] - 1  # the step from one genome's last pointer to the next genome's 0
    n_terms_g = np.delete(np.diff(ptrs), gaps)  # terms of each op, genome-major
    per_genome = np.fromiter((p.term_src.size for p in plans), dtype=np.int64, count=len(plans))
    shift = np.repeat(np.concatenate([[0], np.cumsum(n_ops)[:-1]]), per_genome)  # genome's first op slot - first
    src_raw = np.concatenate([p.term_src for p in plans]).astype(np.int64)
    src_g = np.where(src_raw < first, src_raw, src_raw + shift)
    out_raw = np.stack([p.output_slots for p in plans]).astype(np.int64)
    out_g = np.where(out_raw < first, out_raw, out_raw + np.concatenate([[0], np.cumsum(n_ops)[:-1]])[:, None])
    # every op of every genome, ordered by wave (op index within its genome), genomes in order within a wave
    op_base = np.concatenate([[0], np.cumsum(n_ops)[:-1]]).astype(np.int64)
    k = np.arange(int(n_ops.sum())) - np.repeat(op_base, n_ops)
    order = np.argsort(k, kind="stable")
    k = k[order]
    slot = first + order  # where each op writes: genome-major op number after the shared slots
    act = np.concatenate(acts)[order]
    mode = modes[order].astype(np.int64)
    starts_g = np.concatenate([[0], np.cumsum(n_terms_g)[:-1]]).astype(np.int64)
    n_terms = n_terms_g[order]
    term_ptr = np.concatenate([[0], np.cumsum(n_terms)]).astype(np.int64)
    pick = np.repeat(starts_g[order], n_terms) + (np.arange(int(term_ptr[-1])) - np.repeat(term_ptr[:-1], n_terms))
    term_src = src_g[pick]
    term_w = np.concatenate([p.term_weight for p in plans]).astype(np.float32)[pick]

    v = np.empty((first + int(n_ops.sum()), n_q), dtype=np.float32)
    v[0] = 1.0
    v[1 : 1 + n_in] = x.T
    v[1 + n_in] = 0.0
    wave_ends = np.searchsorted(k, np.arange(1, int(k.max()) + 2 if k.size else 1))
    lo = 0
    for hi in wave_ends.tolist():
        if hi == lo:
            continue
        sums = np.empty((hi - lo, n_q), dtype=np.float32)
        _wave_sums(v, lo, hi, term_ptr, term_src, term_w, mode, sums)
        w_mode, w_act, w_slot = mode[lo:hi], act[lo:hi], slot[lo:hi]
        prod = w_mode == MODE_PRODUCT
        if prod.any():
            v[w_slot[prod]] = sums[prod]
        for code in np.unique(w_act[~prod]).tolist():
            sel = (~prod) & (w_act == code)
            v[w_slot[sel]] = BY_CODE[code](sums[sel])
        lo = hi
    return np.ascontiguousarray(v[out_g].transpose(0, 2, 1))  # (N, Q, n_outputs)
