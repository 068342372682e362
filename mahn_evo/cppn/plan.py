"""Compile a genome once into an evaluation plan, then evaluate it for a whole matrix of queries at once.

The original activates a CPPN recursively for every single query (section 6 of the reference sheet):

1. clear every non-bias signal to 0 (bias = 1), write the inputs;
2. for output 0, then output 1, ..., evaluate depth first: mark the node "in progress", then for each incoming
   connection **in genome connection-list order**: a source that is in progress (a back edge or self-loop)
   contributes ``w * 0``; any other source is evaluated first if it is not done yet, then contributes
   ``w * value``; finally the node is marked done and its value is ``f(sum)``;
3. nodes done while computing an earlier output are reused; per-node bias fields are ignored (only the bias node,
   value 1, acts as a bias); module output nodes have no incoming connections and output 0.

Because every query starts from the same cleared state, which edges are "in progress" does not depend on the
inputs: the traversal is a property of the genome alone.  We therefore run the DFS once, record the post-order
list of nodes with their surviving incoming terms, and replay it with numpy arrays over all Q queries: the result
equals the recursive activation query by query (the accumulation order of every sum is kept, in float32).

With ``evaluate_modules=True`` a Multiply module output is the product of its module inputs, each evaluated
(after its own sources) by the same DFS; an in-progress module input counts as 0.  This is the "intended
behaviour" ablation, off by default.

The plan is plain arrays (CSR terms), so a compiled kernel (numba) or a file can use it directly.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from .activations import BY_CODE, activation_code

if TYPE_CHECKING:  # pragma: no cover
    from ..neat.genome import Genome

__all__ = ["CppnPlan", "compile_cppn", "MODE_SUM", "MODE_PRODUCT"]

MODE_SUM = 0
MODE_PRODUCT = 1
_ZERO = activation_code("zero")
_IDENTITY = activation_code("identity")


@dataclass(frozen=True)
class CppnPlan:
    """A genome's activation, flattened.

    Slots hold one signal each: slot 0 is the bias (1.0), slots 1..n_inputs the inputs in input-id order, slot
    ``n_inputs + 1`` a constant 0, and then one slot per evaluated node in evaluation (post-)order.  Op k writes
    slot ``first_op_slot + k`` from terms ``term_src[term_ptr[k]:term_ptr[k+1]]`` (weights ``term_weight``):
    ``act(sum of w * signal)`` for ``MODE_SUM`` or the product of the signals for ``MODE_PRODUCT``.
    """

    n_inputs: int
    node_ids: np.ndarray  # node id evaluated by op k
    op_act: np.ndarray  # activation code of op k (see activations.ACTIVATIONS)
    op_mode: np.ndarray  # MODE_SUM or MODE_PRODUCT
    term_ptr: np.ndarray  # CSR pointers, length n_ops + 1
    term_src: np.ndarray  # source slot of each term
    term_weight: np.ndarray  # float64 weight of each term (cast to the evaluation dtype)
    output_slots: np.ndarray  # slot of each output, in output order

    @property
    def n_outputs(self) -> int:
        return int(self.output_slots.size)

    @property
    def first_op_slot(self) -> int:
        return self.n_inputs + 2

    @property
    def n_slots(self) -> int:
        return self.first_op_slot + int(self.op_act.size)

    def evaluate(self, inputs: np.ndarray, dtype: type = np.float32) -> np.ndarray:
        """Outputs (Q, n_outputs) for an input matrix (Q, n_inputs), columns in input-id order.

        ``dtype=np.float32`` (default) reproduces the original's float32 signals; ``np.float64`` gives a
        double-precision variant.  For the HyperNEAT CPPN, column 0 of the result is the weight output and
        column 1 the bias output.
        """
        x: np.ndarray = np.asarray(inputs, dtype=dtype)
        if x.ndim == 1:
            x = x[None, :]
        if x.ndim != 2 or x.shape[1] != self.n_inputs:
            raise ValueError(f"CppnPlan.evaluate: expected inputs of shape (Q, {self.n_inputs}), got {x.shape}")
        q = x.shape[0]
        v: np.ndarray = np.empty((self.n_slots, q), dtype=dtype)
        v[0] = 1.0
        v[1 : 1 + self.n_inputs] = x.T
        v[1 + self.n_inputs] = 0.0
        w: np.ndarray = self.term_weight.astype(dtype)
        ptr = self.term_ptr.tolist()
        src = self.term_src.tolist()
        acts = self.op_act.tolist()
        modes = self.op_mode.tolist()
        slot = self.first_op_slot
        acc: np.ndarray
        for k in range(len(acts)):
            a, b = ptr[k], ptr[k + 1]
            if modes[k] == MODE_SUM:
                if a == b:
                    acc = np.zeros(q, dtype=dtype)
                else:
                    acc = w[a] * v[src[a]]
                    for t in range(a + 1, b):
                        acc += w[t] * v[src[t]]
                v[slot] = BY_CODE[acts[k]](acc)
            else:
                acc = np.ones(q, dtype=dtype)
                for t in range(a, b):
                    acc *= v[src[t]]
                v[slot] = acc
            slot += 1
        return np.ascontiguousarray(v[self.output_slots].T)


def compile_cppn(genome: Genome, evaluate_modules: bool = False) -> CppnPlan:
    """Run the original's depth-first activation order once and record it as a :class:`CppnPlan`."""
    builder = _PlanBuilder(genome, evaluate_modules)
    for o in genome.output_ids:
        builder.visit(o)
    return builder.plan(genome.output_ids)


class _PlanBuilder:
    """One genome's plan, built in three named steps: slots for the bias and the inputs (`__init__`), one operation
    per node in the original's depth-first order (`visit`), and the operations packed as arrays (`plan`)."""

    def __init__(self, genome: Genome, evaluate_modules: bool) -> None:
        self.evaluate_modules = evaluate_modules
        self.kinds = {n.id: n.kind for n in genome.nodes}
        self.acts = {n.id: n.activation for n in genome.nodes}
        self.n_in = len(genome.input_ids)
        self.zero_slot = self.n_in + 1
        self.first_op = self.n_in + 2
        self.slot_of: dict[int, int] = {}
        self.state: dict[int, int] = {}  # 1 = in progress, 2 = done
        for n in genome.nodes:
            if n.kind == "bias":
                self.slot_of[n.id] = 0
                self.state[n.id] = 2
        for j, nid in enumerate(genome.input_ids):
            self.slot_of[nid] = 1 + j
            self.state[nid] = 2
        self.incoming: dict[int, list[tuple[int, float]]] = {}
        for s, d, w in zip(genome.src.tolist(), genome.dst.tolist(), genome.weight.tolist()):
            self.incoming.setdefault(d, []).append((s, w))
        self.module_of_out: dict[int, tuple[int, ...]] = {}
        for m in genome.modules:
            for o in m.outputs:
                self.module_of_out[o] = m.inputs
        self.op_nodes: list[int] = []
        self.op_act: list[int] = []
        self.op_mode: list[int] = []
        self.op_terms: list[list[tuple[int | None, float]]] = []  # (source node id or None for the zero slot, weight)

    def sources_of(self, nid: int) -> tuple[list[tuple[int, float]], int]:
        """A node's weighted sources and how they combine (a module output multiplies its inputs when modules are
        evaluated, and reads 0 when they are not, as in the original code)."""
        if self.kinds[nid] == "module_out":
            if self.evaluate_modules:
                return [(i, 1.0) for i in self.module_of_out.get(nid, ())], MODE_PRODUCT
            return [], MODE_SUM
        return self.incoming.get(nid, []), MODE_SUM

    def visit(self, root: int) -> None:
        """Record `root` and every node it depends on, depth first; a source still in progress (a cycle) adds 0."""
        state = self.state
        if state.get(root) == 2:
            return
        # Iterative DFS: frames are [node, sources, mode, next index, terms].
        srcs, mode = self.sources_of(root)
        state[root] = 1
        stack: list[list] = [[root, srcs, mode, 0, []]]
        while stack:
            frame = stack[-1]
            nid, srcs, mode, i, terms = frame
            if i < len(srcs):
                frame[3] = i + 1
                s, w = srcs[i]
                st = state.get(s)
                if st == 1:  # in progress: contributes w * 0
                    if mode == MODE_PRODUCT:
                        terms.append((None, w))
                    continue
                terms.append((s, w))
                if st is None:
                    s_srcs, s_mode = self.sources_of(s)
                    state[s] = 1
                    stack.append([s, s_srcs, s_mode, 0, []])
                continue
            stack.pop()
            self._record(nid, mode, terms)

    def _record(self, nid: int, mode: int, terms: list[tuple[int | None, float]]) -> None:
        self.state[nid] = 2
        self.slot_of[nid] = self.first_op + len(self.op_nodes)
        self.op_nodes.append(nid)
        self.op_mode.append(mode)
        if self.kinds[nid] == "module_out":
            self.op_act.append(_IDENTITY if mode == MODE_PRODUCT else _ZERO)
        else:
            self.op_act.append(activation_code(self.acts[nid]))
        self.op_terms.append(terms)

    def plan(self, outputs: Sequence[int]) -> CppnPlan:
        """The recorded operations as arrays, their terms in compressed rows (`term_ptr`)."""
        ptr = [0]
        t_src: list[int] = []
        t_w: list[float] = []
        for terms in self.op_terms:
            for s, w in terms:
                t_src.append(self.zero_slot if s is None else self.slot_of[s])
                t_w.append(w)
            ptr.append(len(t_src))
        return CppnPlan(
            n_inputs=self.n_in,
            node_ids=np.asarray(self.op_nodes, dtype=np.int64),
            op_act=np.asarray(self.op_act, dtype=np.int64),
            op_mode=np.asarray(self.op_mode, dtype=np.int64),
            term_ptr=np.asarray(ptr, dtype=np.int64),
            term_src=np.asarray(t_src, dtype=np.int64),
            term_weight=np.asarray(t_w, dtype=np.float64),
            output_slots=np.asarray([self.slot_of[o] for o in outputs], dtype=np.int64),
        )
