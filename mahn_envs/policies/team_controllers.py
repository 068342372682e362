"""Team controllers as plain arrays (see core.controller for the layout) and their file format.

The same `TeamControllers` drives the batch core, the PettingZoo env (`ControllerPolicy`) and real robots.
Files are JSON (human-readable, versioned) so a champion can be inspected, diffed and loaded anywhere.
"""
from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..core.controller import DECISIONS

N_INPUTS = 7
N_HIDDEN = 9
N_OUTPUTS = 3
_FIELDS = ("w_ih", "w_hh", "w_ho", "b_h", "b_o")


@dataclass(frozen=True, eq=False)
class TeamControllers:
    """Controllers of one team (arrays (R, K, ...)) or of a batch of teams (arrays (B, R, K, ...)).

    K = 2 brains means situational policy geometry (switch at the signal, fresh state);
    K = 1 means standard geometry (the signal is input 6).  `decision` is how the outputs become an action
    (core.controller.DECISIONS): part of the team, because the same weights act differently under each rule.
    """

    w_ih: np.ndarray
    w_hh: np.ndarray
    w_ho: np.ndarray
    b_h: np.ndarray
    b_o: np.ndarray
    decision: str = "output"

    def __post_init__(self) -> None:
        if self.decision not in DECISIONS:
            raise ValueError(f"controllers: decision must be one of {DECISIONS}, got {self.decision!r}")
        arrays = {}
        for name in _FIELDS:
            a = np.ascontiguousarray(getattr(self, name), dtype=np.float32)
            if not np.all(np.isfinite(a)):
                raise ValueError(f"controller array {name!r} contains NaN or infinity")
            arrays[name] = a
            object.__setattr__(self, name, a)
        w_ih = arrays["w_ih"]
        if w_ih.ndim not in (4, 5):
            raise ValueError(f"controller array 'w_ih' must have shape (R, K, H, 7) or (B, R, K, H, 7), "
                             f"got {w_ih.shape}")
        lead = w_ih.shape[:-2]
        n_hidden = w_ih.shape[-2]
        expected = {"w_ih": lead + (n_hidden, N_INPUTS), "w_hh": lead + (n_hidden, n_hidden),
                    "w_ho": lead + (N_OUTPUTS, n_hidden), "b_h": lead + (n_hidden,), "b_o": lead + (N_OUTPUTS,)}
        for name, shape in expected.items():
            if arrays[name].shape != shape:
                raise ValueError(f"controller array {name!r} has shape {arrays[name].shape}, expected {shape}")
        if lead[-1] not in (1, 2):
            raise ValueError(f"controllers must have 1 (standard) or 2 (situational) brains, got {lead[-1]}")

    @property
    def batched(self) -> bool:
        return self.w_ih.ndim == 5

    @property
    def n_robots(self) -> int:
        return self.w_ih.shape[-4]

    @property
    def n_brains(self) -> int:
        return self.w_ih.shape[-3]

    @property
    def mode(self) -> str:
        return "situational" if self.n_brains == 2 else "standard"

    def as_batch(self) -> TeamControllers:
        """A batch of one team (no copy when already batched)."""
        if self.batched:
            return self
        return self.map_arrays(lambda a: a[None])

    def map_arrays(self, fn: Callable[[np.ndarray], np.ndarray]) -> TeamControllers:
        """The controllers whose every array is fn(array), deciding by the same rule (slices, repeats, copies)."""
        return TeamControllers(fn(self.w_ih), fn(self.w_hh), fn(self.w_ho), fn(self.b_h), fn(self.b_o), self.decision)

    def repeated(self, n: int) -> TeamControllers:
        """The batch's teams repeated n times along the batch axis (one team acting in n lock-step episodes)."""
        return self.as_batch().map_arrays(lambda a: np.repeat(a, int(n), axis=0))

    def team(self, index: int) -> TeamControllers:
        if not self.batched:
            raise ValueError("team(index) needs a batch of teams")
        return self.map_arrays(lambda a: a[index])

    def with_decision(self, decision: str) -> TeamControllers:
        """The same networks deciding by `decision` (core.controller.DECISIONS); the arrays are shared."""
        return TeamControllers(self.w_ih, self.w_hh, self.w_ho, self.b_h, self.b_o, decision)

    @staticmethod
    def stack(teams: list[TeamControllers]) -> TeamControllers:
        """One batch of the teams (each (R, K, ...)), which must decide by one rule."""
        rules = {t.decision for t in teams}
        if len(rules) > 1:
            raise ValueError(f"cannot stack teams that decide by different rules {sorted(rules)}")
        w_ih, w_hh, w_ho, b_h, b_o = (np.stack([getattr(t, f) for t in teams]) for f in _FIELDS)
        return TeamControllers(w_ih, w_hh, w_ho, b_h, b_o, rules.pop() if rules else "output")

    def to_dict(self) -> dict[str, Any]:
        """Plain JSON: nested lists of float32 values (exact through float64 JSON round trip)."""
        return {"mode": self.mode, "n_robots": self.n_robots, "n_brains": self.n_brains,
                "layout": "w_ih[r][k][hidden][input], w_hh[r][k][target][source], w_ho[r][k][output][hidden], "
                          "b_h[r][k][hidden], b_o[r][k][output]; inputs: 6 IR (left first) then signal; "
                          "outputs: left, forward, right",
                "decision": self.decision,
                **{f: getattr(self, f).astype(np.float64).tolist() for f in _FIELDS}}

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> TeamControllers:
        """Controllers from `to_dict`'s JSON; without "decision" (files before it existed) they decide by the
        outputs, the only rule there was."""
        missing = [f for f in _FIELDS if f not in data]
        if missing:
            raise ValueError(f"controllers: missing field(s) {missing}")
        decision = data.get("decision", "output")
        if decision not in DECISIONS:
            raise ValueError(f"controllers: field 'decision' must be one of {DECISIONS}, got {decision!r}")
        arrays = []
        for f in _FIELDS:
            try:
                raw = np.asarray(data[f])
            except (TypeError, ValueError) as exc:
                raise ValueError(f"controllers: field {f!r} is not a regular array of numbers ({exc})") from exc
            if raw.dtype.kind not in "iuf":  # np.float32("1.5") would silently accept a string
                raise TypeError(f"controllers: field {f!r} must hold numbers, got {raw.dtype.name} values")
            arrays.append(raw.astype(np.float32))
        w_ih, w_hh, w_ho, b_h, b_o = arrays
        return cls(w_ih, w_hh, w_ho, b_h, b_o, decision)
