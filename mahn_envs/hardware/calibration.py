"""Calibrations: raw Khepera III IR counts -> the simulator's [0, 1] sensor scale, and back.

The simulator's sensor value is the gap between the robot's surface and the wall in units of the IR range
(10.16 cm): 1 = nothing in range, 0 = touching.  A real IR sensor returns a 12-bit reflection count that rises
as the gap shrinks.  A calibration maps one to the other:

``to_unit(raw) -> [0, 1]``  used by the hardware env on every ``N`` reply;
``to_raw(unit) -> counts``  its inverse, used by the emulator to synthesise ``N`` replies from the simulator.

Three are provided; any object with these two methods (or a plain function for ``to_unit`` only, wrapped by
:func:`make_calibration`) can be passed as ``Sensing(calibration=...)`` to the env:

- :class:`LogCalibration` (default, ``"paper"``): the paper's ``1.43 - (log10(s) - 0.51) / 2.25``, clipped.
  It puts raw 30 at 1.0 (about 12 cm) and raw ~1460 at 0.25 (about 2.6 cm), close to the simulator's scale.
- :class:`LinearCalibration` (``"linear"``): the original deployment code's ``1 - min(1, raw / 4000)``.
- :class:`TableCalibration`: piecewise-linear through your own measured (raw, unit) pairs - the way to
  calibrate a particular robot (see docs/hardware.md).
"""
from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..khepera import IR_CALIBRATION_A, IR_CALIBRATION_B, IR_CALIBRATION_C, IR_NOISE_GAP_M, IR_NOISE_SIGMA, IR_RAW_MAX

RAW_MAX = IR_RAW_MAX  # 12-bit converter


@dataclass(frozen=True)
class LogCalibration:
    """``unit = a - (log10(raw) - b) / c`` clipped to [0, 1]; raw below 1 counts as 1 (nothing reflected)."""

    a: float = IR_CALIBRATION_A
    b: float = IR_CALIBRATION_B
    c: float = IR_CALIBRATION_C
    name: str = "paper"

    def to_unit(self, raw: Any) -> np.ndarray:
        s = np.maximum(np.asarray(raw, dtype=np.float64), 1.0)
        return np.clip(self.a - (np.log10(s) - self.b) / self.c, 0.0, 1.0)

    def to_raw(self, unit: Any) -> np.ndarray:
        """Inverse on the unclipped scale: any unit value (also < 0 or > 1) -> counts, capped to 12 bits."""
        u = np.asarray(unit, dtype=np.float64)
        return np.clip(10.0 ** (self.b + (self.a - u) * self.c), 0.0, RAW_MAX)


@dataclass(frozen=True)
class LinearCalibration:
    """``unit = 1 - min(1, raw / full_scale)`` (the original deployment code, full_scale 4000)."""

    full_scale: float = 4000.0
    name: str = "linear"

    def to_unit(self, raw: Any) -> np.ndarray:
        return np.clip(1.0 - np.asarray(raw, dtype=np.float64) / self.full_scale, 0.0, 1.0)

    def to_raw(self, unit: Any) -> np.ndarray:
        u = np.clip(np.asarray(unit, dtype=np.float64), 0.0, 1.0)
        return np.clip((1.0 - u) * self.full_scale, 0.0, RAW_MAX)


class TableCalibration:
    """Piecewise-linear interpolation through measured points (raw counts, unit value), clamped at the ends.

    Measure by placing a robot at known gaps g (cm) from a wall, reading ``N``, and using unit = g / 10.16.
    Raw must be strictly increasing and unit non-increasing (more reflection = closer).
    """

    def __init__(self, raw: Sequence[float], unit: Sequence[float], name: str = "table") -> None:
        r = np.asarray(raw, dtype=np.float64)
        u = np.asarray(unit, dtype=np.float64)
        if r.ndim != 1 or r.shape != u.shape or r.size < 2:
            raise ValueError("TableCalibration needs two equally long lists of at least 2 points")
        if not (np.all(np.isfinite(r)) and np.all(np.isfinite(u))):
            raise ValueError("TableCalibration points must be finite")
        if np.any(np.diff(r) <= 0):
            raise ValueError("TableCalibration raw values must be strictly increasing")
        if np.any(np.diff(u) > 0):
            raise ValueError("TableCalibration unit values must not increase with raw (closer = more light)")
        self.raw = r
        self.unit = u
        self.name = name

    def to_unit(self, raw: Any) -> np.ndarray:
        return np.clip(np.interp(np.asarray(raw, dtype=np.float64), self.raw, self.unit), 0.0, 1.0)

    def to_raw(self, unit: Any) -> np.ndarray:
        u = np.asarray(unit, dtype=np.float64)
        # np.interp needs increasing x: walk the table backwards
        return np.clip(np.interp(u, self.unit[::-1], self.raw[::-1]), 0.0, RAW_MAX)


class _FunctionCalibration:
    def __init__(self, fn: Callable[[np.ndarray], Any]) -> None:
        self.fn = fn
        self.name = getattr(fn, "__name__", "custom")

    def to_unit(self, raw: Any) -> np.ndarray:
        return np.clip(np.asarray(self.fn(np.asarray(raw, dtype=np.float64)), dtype=np.float64), 0.0, 1.0)

    def to_raw(self, unit: Any) -> np.ndarray:
        raise NotImplementedError(f"calibration {self.name!r} is a plain function and has no inverse; give the "
                                  "emulator an object with to_raw()")


Calibration = LogCalibration | LinearCalibration | TableCalibration | Any

PAPER = LogCalibration()
LINEAR = LinearCalibration()
_NAMED = {"paper": PAPER, "log": PAPER, "linear": LINEAR, "original": LINEAR}


def make_calibration(spec: Any = "paper") -> Any:
    """A name ("paper"/"log", "linear"/"original"), an object with ``to_unit``, or a function raw -> unit."""
    if isinstance(spec, str):
        try:
            return _NAMED[spec]
        except KeyError:
            raise ValueError(f"unknown calibration {spec!r}; known: {sorted(_NAMED)}") from None
    if hasattr(spec, "to_unit"):
        return spec
    if callable(spec):
        return _FunctionCalibration(spec)
    raise ValueError(f"calibration must be a name, an object with to_unit(), or a function; got {spec!r}")


# Relative noise (Gaussian sigma / value) of a real Khepera III IR sensor against the gap in metres
# (mahn_envs.khepera: K-Team's calibration as used by the Webots model).  Used by the emulator.
NOISE_GAP_M = IR_NOISE_GAP_M
NOISE_SIGMA = IR_NOISE_SIGMA


def relative_noise(gap_cm: Any) -> np.ndarray:
    """Relative sigma of a reading at `gap_cm` centimetres from the sensor (interpolated, clamped)."""
    return np.interp(np.asarray(gap_cm, dtype=np.float64) / 100.0, NOISE_GAP_M, NOISE_SIGMA)
