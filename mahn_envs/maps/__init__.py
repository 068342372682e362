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

from ..jsonfile import read_json_object
from ..khepera import DEFAULT_MODEL

BUILTIN_MAPS = ("plus", "asymmetric_plus")

#: largest coordinate a map may use (cm): 1 km.  Larger values are typos, and far larger ones overflow the
#: squared distances of the geometry kernels.
MAX_COORDINATE = 1e5

#: directions in which a start pose must meet a wall: a start from which a ray escapes lies outside every corridor
_ENCLOSURE_RAYS = 72


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
        if isinstance(v, bool) or not isinstance(v, (int, float)):
            raise ValueError(f"map field {field!r} must hold finite numbers, got {value!r}")
        try:
            f = float(v)
        except OverflowError:  # an int too large for a float
            f = math.inf
        if not math.isfinite(f) or abs(f) > MAX_COORDINATE:
            raise ValueError(f"map field {field!r} must hold finite numbers within +-{MAX_COORDINATE:g} cm, got "
                             f"{value!r}")
        out.append(f)
    return out


def _point_segment_distance(px: float, py: float, w: np.ndarray) -> float:
    ex, ey = w[2] - w[0], w[3] - w[1]
    t = min(1.0, max(0.0, ((px - w[0]) * ex + (py - w[1]) * ey) / (ex * ex + ey * ey)))
    return math.hypot(px - (w[0] + t * ex), py - (w[1] + t * ey))


def _segment_meets_box(w: np.ndarray, x0: float, y0: float, x1: float, y1: float) -> bool:
    """Liang-Barsky: does the segment w touch the closed box [x0, x1] x [y0, y1]?"""
    t0, t1 = 0.0, 1.0
    dx, dy = w[2] - w[0], w[3] - w[1]
    for p, q in ((-dx, w[0] - x0), (dx, x1 - w[0]), (-dy, w[1] - y0), (dy, y1 - w[1])):
        if p == 0.0:
            if q < 0.0:
                return False
            continue
        t = q / p
        if p < 0.0:
            t0 = max(t0, t)
        else:
            t1 = min(t1, t)
        if t0 > t1:
            return False
    return True


def wall_clearance(walls: np.ndarray, x: float, y: float, half: float = 0.0) -> tuple[float, int]:
    """(distance, wall index) of the wall nearest to the square of half-width `half` around (x, y) (a point for
    half = 0): a robot of radius r anywhere in the square keeps clear of every wall iff distance >= r."""
    x0, y0, x1, y1 = x - half, y - half, x + half, y + half
    best, best_i = math.inf, -1
    for i, w in enumerate(walls):
        if _segment_meets_box(w, x0, y0, x1, y1):
            return 0.0, i
        d = min([math.hypot(max(x0 - px, 0.0, px - x1), max(y0 - py, 0.0, py - y1))
                 for px, py in ((w[0], w[1]), (w[2], w[3]))]
                + [_point_segment_distance(cx, cy, w) for cx, cy in ((x0, y0), (x0, y1), (x1, y0), (x1, y1))])
        if d < best:
            best, best_i = d, i
    return best, best_i


def escaping_direction(walls: np.ndarray, x: float, y: float) -> float | None:
    """A direction (rad) in which a ray from (x, y) meets no wall, or None if walls enclose the point."""
    reach = 4.0 * MAX_COORDINATE
    for k in range(_ENCLOSURE_RAYS):
        a = 2.0 * math.pi * k / _ENCLOSURE_RAYS
        dx, dy = reach * math.cos(a), reach * math.sin(a)
        ex, ey = walls[:, 2] - walls[:, 0], walls[:, 3] - walls[:, 1]
        ax, ay = walls[:, 0] - x, walls[:, 1] - y
        denom = dx * ey - dy * ex
        with np.errstate(divide="ignore", invalid="ignore"):
            r = (ax * ey - ay * ex) / denom
            t = (ax * dy - ay * dx) / denom
        if not np.any((denom != 0.0) & (r >= 0.0) & (r <= 1.0) & (t >= 0.0) & (t <= 1.0)):
            return a
    return None


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
    radius = DEFAULT_MODEL.radius
    for i, (x, y, _) in enumerate(starts):
        gap, w = wall_clearance(walls, x, y)
        if gap < radius:
            raise ValueError(f"map {source}: field 'starts[{i}]' = ({x}, {y}) lies {gap:.3g} cm from walls[{w}]: "
                             f"a robot (radius {radius} cm) placed there would start on or inside the wall")
        escape = escaping_direction(walls, x, y)
        if escape is not None:
            raise ValueError(f"map {source}: field 'starts[{i}]' = ({x}, {y}) lies outside every corridor: no wall "
                             f"encloses it (a ray at {math.degrees(escape):.0f} degrees leaves the arena)")
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
    if not spec.strip():
        raise ValueError(f"map must be a built-in map {BUILTIN_MAPS} or a JSON file, got an empty path")
    path = Path(spec)
    if not path.exists():
        raise ValueError(f"unknown map {spec!r}: not a built-in map {BUILTIN_MAPS} and no such file")
    data = read_json_object(path, "map")
    return world_from_dict(data, source=spec)
