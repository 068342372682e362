"""The NEAT genome: node genes, module genes and connection genes, stored compactly.

Why this representation: a generation makes hundreds of children that each differ from a parent by one mutation.
Connection genes therefore live in four parallel, read-only numpy arrays (innovation, source, target, weight),
sorted by innovation id, and node/module genes in immutable tuples.  A child shares every array and tuple it does
not change (a weight mutation copies only the weight array), so reproduction costs microseconds per genome, and the
read-only flags make accidental aliasing bugs fail loudly.

Node kinds follow the original CPPN genomes: one ``bias`` node (value 1), ``input`` nodes (CPPN coordinates, in id
order), ``output`` nodes (in id order), ``hidden`` nodes, and the dummy ``module_in`` / ``module_out`` nodes of
modules such as the seed genome's Multiply modules.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from typing import Any, NamedTuple

import numpy as np

from ..cppn.activations import ACTIVATIONS
from .innovation import InnovationTracker

__all__ = ["NODE_KINDS", "NodeGene", "ModuleGene", "Genome", "InnovationTracker"]

NODE_KINDS = ("bias", "input", "output", "hidden", "module_in", "module_out")
MODULE_FUNCTIONS = ("multiply",)


class NodeGene(NamedTuple):
    """A neuron: stable id (shared innovation counter), kind, activation function name."""

    id: int
    kind: str
    activation: str


class ModuleGene(NamedTuple):
    """A module (e.g. Multiply): its function and the ids of its dummy input and output nodes."""

    id: int
    function: str
    inputs: tuple[int, ...]
    outputs: tuple[int, ...]


def _ro(a: np.ndarray) -> np.ndarray:
    a.flags.writeable = False
    return a


class _NodeInfo:
    """Per node-set derived data, shared by every genome with the same node tuple (children of one parent)."""

    __slots__ = ("ids", "kinds", "id_set", "sources", "targets", "inputs", "outputs", "n_hidden")

    def __init__(self, nodes: tuple[NodeGene, ...]) -> None:
        self.ids = np.fromiter((n.id for n in nodes), dtype=np.int64, count=len(nodes))
        self.kinds = tuple(n.kind for n in nodes)
        self.id_set = frozenset(n.id for n in nodes)
        # Add-connection candidates (original): sources are all neurons except module-input dummies; targets are
        # outputs and hidden neurons that are not module dummies.
        self.sources = np.array([n.id for n in nodes if n.kind != "module_in"], dtype=np.int64)
        self.targets = np.array([n.id for n in nodes if n.kind in ("output", "hidden")], dtype=np.int64)
        self.inputs = tuple(n.id for n in nodes if n.kind == "input")
        self.outputs = tuple(n.id for n in nodes if n.kind == "output")
        self.n_hidden = sum(1 for n in nodes if n.kind == "hidden")


class Genome:
    """An immutable NEAT genome.  Build new genomes with the constructor or :meth:`evolve`; never mutate arrays."""

    __slots__ = ("nodes", "modules", "innov", "src", "dst", "weight", "_info")

    def __init__(
        self,
        nodes: Iterable[NodeGene | Sequence[Any]],
        innov: Any,
        src: Any,
        dst: Any,
        weight: Any,
        modules: Iterable[ModuleGene | Sequence[Any]] = (),
        *,
        _info: _NodeInfo | None = None,
        _sorted: bool = False,
    ) -> None:
        nodes_t = nodes if isinstance(nodes, tuple) and all(type(n) is NodeGene for n in nodes) else None
        if nodes_t is None:
            nodes_t = tuple(NodeGene(int(n[0]), str(n[1]), str(n[2])) for n in nodes)
        if not _sorted and any(nodes_t[i].id >= nodes_t[i + 1].id for i in range(len(nodes_t) - 1)):
            nodes_t = tuple(sorted(nodes_t, key=lambda n: n.id))
            _info = None
        self.nodes: tuple[NodeGene, ...] = nodes_t
        self.modules: tuple[ModuleGene, ...] = tuple(
            m if type(m) is ModuleGene
            else ModuleGene(int(m[0]), str(m[1]), tuple(map(int, m[2])), tuple(map(int, m[3])))
            for m in modules
        )
        innov_a = np.asarray(innov, dtype=np.int64)
        src_a = np.asarray(src, dtype=np.int64)
        dst_a = np.asarray(dst, dtype=np.int64)
        w_a = np.asarray(weight, dtype=np.float64)
        if not (innov_a.shape == src_a.shape == dst_a.shape == w_a.shape and innov_a.ndim == 1):
            raise ValueError("Genome: connection arrays must be 1-D and of equal length")
        if not _sorted and innov_a.size > 1 and np.any(np.diff(innov_a) < 0):
            order = np.argsort(innov_a, kind="stable")
            innov_a, src_a, dst_a, w_a = innov_a[order], src_a[order], dst_a[order], w_a[order]
        self.innov = _ro(innov_a)
        self.src = _ro(src_a)
        self.dst = _ro(dst_a)
        self.weight = _ro(w_a)
        self._info = _info if _info is not None else _NodeInfo(self.nodes)

    # ------------------------------------------------------------------------------------------------ derived
    @property
    def n_connections(self) -> int:
        return int(self.innov.size)

    @property
    def input_ids(self) -> tuple[int, ...]:
        """Input node ids in column order of a CPPN query."""
        return self._info.inputs

    @property
    def output_ids(self) -> tuple[int, ...]:
        """Output node ids in output order (original: 0 = weight, 1 = bias)."""
        return self._info.outputs

    @property
    def n_hidden(self) -> int:
        return self._info.n_hidden

    @property
    def complexity(self) -> int:
        """Neurons + connections, the quantity the original's re-speciation rule watches."""
        return len(self.nodes) + int(self.innov.size)

    @property
    def node_ids(self) -> frozenset[int]:
        return self._info.id_set

    def with_weights(self, weight: np.ndarray) -> Genome:
        """A genome identical to this one except for the weight array (shares everything else)."""
        return Genome(
            self.nodes, self.innov, self.src, self.dst, weight, self.modules, _info=self._info, _sorted=True
        )

    def pair_keys(self) -> np.ndarray:
        """One int64 per connection identifying its (src, dst) pair."""
        return self.src * (1 << 32) + self.dst

    # ------------------------------------------------------------------------------------------------ checks
    def validate(self, weight_limit: float | None = None) -> None:
        """Raise ValueError naming the first inconsistency found; return None if the genome is well formed."""
        ids = [n.id for n in self.nodes]
        if len(set(ids)) != len(ids):
            dup = sorted({i for i in ids if ids.count(i) > 1})
            raise ValueError(f"Genome: duplicate node id(s) {dup}")
        for n in self.nodes:
            if n.kind not in NODE_KINDS:
                raise ValueError(f"Genome: node {n.id} has unknown kind {n.kind!r}")
            if n.activation not in ACTIVATIONS:
                raise ValueError(f"Genome: node {n.id} has unknown activation {n.activation!r}")
        kinds = {n.id: n.kind for n in self.nodes}
        n_bias = sum(1 for n in self.nodes if n.kind == "bias")
        if n_bias != 1:
            raise ValueError(f"Genome: expected exactly one bias node, found {n_bias}")
        if not self._info.outputs:
            raise ValueError("Genome: no output node")
        if self.innov.size:
            if np.any(np.diff(self.innov) <= 0):
                d = self.innov[np.flatnonzero(np.diff(self.innov) <= 0)[0] + 1]
                raise ValueError("Genome: connection innovations not strictly increasing "
                                 f"(duplicate or unsorted at {int(d)})")
            keys = self.pair_keys()
            uk, counts = np.unique(keys, return_counts=True)
            if np.any(counts > 1):
                k = int(uk[np.argmax(counts > 1)])
                raise ValueError(f"Genome: duplicate connection endpoints ({k >> 32} -> {k & 0xFFFFFFFF})")
            if not np.all(np.isfinite(self.weight)):
                raise ValueError("Genome: non-finite connection weight")
            if weight_limit is not None and np.any(np.abs(self.weight) > weight_limit):
                i = int(np.argmax(np.abs(self.weight) > weight_limit))
                raise ValueError(
                    f"Genome: weight {self.weight[i]!r} of connection {int(self.innov[i])} outside +-{weight_limit}"
                )
            node_id_set = set(ids)
            conn_ids = set(self.innov.tolist())
            clash = conn_ids & node_id_set
            if clash:
                raise ValueError(f"Genome: id(s) {sorted(clash)} used by both a node and a connection")
            for i, s, d in zip(self.innov.tolist(), self.src.tolist(), self.dst.tolist()):
                if s not in kinds:
                    raise ValueError(f"Genome: connection {i} source {s} is not a node")
                if d not in kinds:
                    raise ValueError(f"Genome: connection {i} target {d} is not a node")
                if kinds[s] == "module_in":
                    raise ValueError(f"Genome: connection {i} starts at module input dummy {s}")
                if kinds[d] not in ("output", "hidden", "module_in"):
                    raise ValueError(f"Genome: connection {i} ends at {kinds[d]} node {d}")
        seen: dict[int, int] = {}
        for m in self.modules:
            if m.function not in MODULE_FUNCTIONS:
                raise ValueError(f"Genome: module {m.id} has unknown function {m.function!r}")
            if not m.inputs or not m.outputs:
                raise ValueError(f"Genome: module {m.id} needs at least one input and one output")
            for nid, want in [(i, "module_in") for i in m.inputs] + [(o, "module_out") for o in m.outputs]:
                if kinds.get(nid) != want:
                    raise ValueError(f"Genome: module {m.id} node {nid} is not a {want} node")
                if nid in seen:
                    raise ValueError(f"Genome: node {nid} belongs to modules {seen[nid]} and {m.id}")
                seen[nid] = m.id
        for n in self.nodes:
            if n.kind in ("module_in", "module_out") and n.id not in seen:
                raise ValueError(f"Genome: {n.kind} node {n.id} belongs to no module")

    # ------------------------------------------------------------------------------------------------ I/O
    def to_dict(self) -> dict[str, Any]:
        """JSON-able dict; floats survive ``json.dumps``/``loads`` exactly (repr round-trips)."""
        return {
            "nodes": [[n.id, n.kind, n.activation] for n in self.nodes],
            "connections": [
                [i, s, d, w]
                for i, s, d, w in zip(self.innov.tolist(), self.src.tolist(), self.dst.tolist(), self.weight.tolist())
            ],
            "modules": [[m.id, m.function, list(m.inputs), list(m.outputs)] for m in self.modules],
        }

    @classmethod
    def from_dict(cls, data: dict[str, Any], validate: bool = True) -> Genome:
        """Inverse of :meth:`to_dict`; validates by default (a bad file fails with the inconsistency named)."""
        try:
            conns = data["connections"]
            nodes = data["nodes"]
        except KeyError as e:
            raise ValueError(f"Genome: missing field {e.args[0]!r}") from None
        arr = np.asarray(conns, dtype=np.float64).reshape(-1, 4) if len(conns) else np.zeros((0, 4))
        g = cls(
            nodes,
            np.asarray([c[0] for c in conns], dtype=np.int64),
            np.asarray([c[1] for c in conns], dtype=np.int64),
            np.asarray([c[2] for c in conns], dtype=np.int64),
            arr[:, 3].copy(),
            data.get("modules", ()),
        )
        if validate:
            g.validate()
        return g

    # ------------------------------------------------------------------------------------------------ misc
    def __eq__(self, other: object) -> bool:
        if not isinstance(other, Genome):
            return NotImplemented
        return (
            self.nodes == other.nodes
            and self.modules == other.modules
            and np.array_equal(self.innov, other.innov)
            and np.array_equal(self.src, other.src)
            and np.array_equal(self.dst, other.dst)
            and np.array_equal(self.weight, other.weight)
        )

    __hash__ = None  # type: ignore[assignment]

    def __repr__(self) -> str:
        return f"Genome(nodes={len(self.nodes)}, hidden={self.n_hidden}, connections={self.n_connections})"

