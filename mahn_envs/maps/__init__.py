"""Maps: the arena a task runs in, loaded from JSON and validated field by field.

A map is data, not code, so users can draw their own arenas; validation names the offending field because a
typo in a hand-written JSON file should never surface as a numba crash deep in the simulator.
"""
from __future__ import annotations

import json
import math
from collections.abc import Mapping
from dataclasses import dataclass
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np

BUILTIN_MAPS = ("plus", "asymmetric_plus")


@dataclass(frozen=True, eq=False)
class World:
    """A validated arena in the y-up frame: wall segments, home, points of interest and start poses."""

    name: str
    walls: np.ndarray  # (W, 4) float64: x1, y1, x2, y2
    home: np.ndarray  # (2,)
    pois: np.ndarray  # (P, 2)
    starts: np.ndarray  # (R, 3): x, y, heading
    description: str = ""

    @property
    def n_robots(self) -> int:
        return int(self.starts.shape[0])

    @property
    def bounds(self) -> tuple[float, float, float, float]:
        """(xmin, ymin, xmax, ymax) of the walls: poses outside it are outside the arena."""
        w = self.walls
        return (float(min(w[:, 0].min(), w[:, 2].min())), float(min(w[:, 1].min(), w[:, 3].min())),
                float(max(w[:, 0].max(), w[:, 2].max())), float(max(w[:, 1].max(), w[:, 3].max())))

    def to_dict(self) -> dict[str, Any]:
        return {"name": self.name, "description": self.description, "walls": self.walls.tolist(),
                "home": self.home.tolist(), "pois": self.pois.tolist(), "starts": self.starts.tolist()}


def _number_list(value: Any, field: str, length: int) -> list[float]:
    if not isinstance(value, (list, tuple)) or len(value) != length:
        raise ValueError(f"map field {field!r} must be a list of {length} numbers, got {value!r}")
    out = []
    for v in value:
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
            raise ValueError(f"map field {field!r} must hold finite numbers, got {value!r}")
        out.append(float(v))
    return out


def _list_of(value: Any, field: str, length: int, min_items: int) -> np.ndarray:
    if not isinstance(value, (list, tuple)) or len(value) < min_items:
        raise ValueError(f"map field {field!r} must be a list of at least {min_items} entries")
    return np.array([_number_list(v, f"{field}[{i}]", length) for i, v in enumerate(value)], dtype=np.float64)


def world_from_dict(data: Mapping[str, Any], source: str = "<dict>") -> World:
    """Validate a map mapping (schema in docs/architecture.md) and build a :class:`World`."""
    if not isinstance(data, Mapping):
        raise ValueError(f"map {source}: top level must be a JSON object")
    allowed = {"name", "description", "walls", "home", "pois", "starts"}
    unknown = set(data) - allowed
    if unknown:
        raise ValueError(f"map {source}: unknown field(s) {sorted(unknown)}; allowed: {sorted(allowed)}")
    for key in ("name", "walls", "home", "pois", "starts"):
        if key not in data:
            raise ValueError(f"map {source}: missing field {key!r}")
    name = data["name"]
    if not isinstance(name, str) or not name:
        raise ValueError(f"map {source}: field 'name' must be a non-empty string")
    walls = _list_of(data["walls"], "walls", 4, 1)
    lengths = np.hypot(walls[:, 2] - walls[:, 0], walls[:, 3] - walls[:, 1])
    if np.any(lengths <= 0):
        i = int(np.argmin(lengths))
        raise ValueError(f"map {source}: field 'walls[{i}]' has zero length")
    home = np.array(_number_list(data["home"], "home", 2))
    pois = _list_of(data["pois"], "pois", 2, 1)
    starts = _list_of(data["starts"], "starts", 3, 1)
    world = World(name=name, walls=walls, home=home, pois=pois, starts=starts,
                  description=str(data.get("description", "")))
    xmin, ymin, xmax, ymax = world.bounds
    for field, pts in (("home", home[None]), ("pois", pois), ("starts", starts[:, :2])):
        for i, (x, y) in enumerate(pts):
            if not (xmin <= x <= xmax and ymin <= y <= ymax):
                label = field if field == "home" else f"{field}[{i}]"
                raise ValueError(f"map {source}: field {label!r} = ({x}, {y}) lies outside the walls' extent "
                                 f"[{xmin}, {xmax}] x [{ymin}, {ymax}]")
    return world


def load_map(map_spec: str | Path | Mapping[str, Any] | World) -> World:
    """Load a built-in map by name, a map JSON file by path, or validate a mapping."""
    if isinstance(map_spec, World):
        return map_spec
    if isinstance(map_spec, Mapping):
        return world_from_dict(map_spec)
    spec = str(map_spec)
    if spec in BUILTIN_MAPS:
        text = resources.files(__package__).joinpath("data").joinpath(f"{spec}.json").read_text()
        return world_from_dict(json.loads(text), source=spec)
    path = Path(spec)
    if not path.exists():
        raise ValueError(f"unknown map {spec!r}: not a built-in map {BUILTIN_MAPS} and no such file")
    try:
        data = json.loads(path.read_text())
    except json.JSONDecodeError as exc:
        raise ValueError(f"map {spec}: not valid JSON ({exc})") from exc
    return world_from_dict(data, source=spec)
