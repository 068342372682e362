"""Innovation ids: one counter for neurons and connections, plus this generation's structural-mutation tables.

Why: crossover and speciation line genes up by innovation id, so the same structural change made twice in one
generation must get the same ids.  The original keys add-connection by (src, dst) and add-node by the id of the
split connection, and clears both tables once per generation (at the start of the asexual phase); we do the same.
Neurons and connections share one counter, as in the original (the seed genomes' counter starts at 610).
"""

from __future__ import annotations

from typing import Any


class InnovationTracker:
    """Hands out fresh ids and remembers this generation's structural innovations."""

    __slots__ = ("next_id", "connections", "splits")

    def __init__(self, next_id: int) -> None:
        if next_id < 0:
            raise ValueError(f"InnovationTracker: next_id must be >= 0, got {next_id}")
        self.next_id = int(next_id)
        #: (src, dst) -> connection innovation id, for connections added this generation.
        self.connections: dict[tuple[int, int], int] = {}
        #: split connection id -> (new node id, its activation, in-connection id, out-connection id).
        self.splits: dict[int, tuple[int, str, int, int]] = {}

    def new_id(self) -> int:
        """A fresh id (never used before in this run)."""
        i = self.next_id
        self.next_id += 1
        return i

    def new_generation(self) -> None:
        """Forget this generation's innovations (ids stay unique: the counter keeps running)."""
        self.connections.clear()
        self.splits.clear()

    def connection_id(self, src: int, dst: int) -> int:
        """The id of connection (src, dst): reused if it appeared this generation, otherwise fresh."""
        key = (src, dst)
        i = self.connections.get(key)
        if i is None:
            i = self.new_id()
            self.connections[key] = i
        return i

    def to_dict(self) -> dict[str, Any]:
        """JSON-able state (the tables are included so a mid-generation snapshot is complete)."""
        return {
            "next_id": self.next_id,
            "connections": [[s, d, i] for (s, d), i in self.connections.items()],
            "splits": [[c, n, a, i, o] for c, (n, a, i, o) in self.splits.items()],
        }

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> InnovationTracker:
        t = cls(int(data["next_id"]))
        for s, d, i in data.get("connections", []):
            t.connections[(int(s), int(d))] = int(i)
        for c, n, a, i, o in data.get("splits", []):
            t.splits[int(c)] = (int(n), str(a), int(i), int(o))
        return t
