"""Clocks shared by the hardware env's pacing and the emulator's motion.

Both sides ask a clock for "robot time" in seconds.  :class:`RealClock` is wall time, optionally sped up by a
`time_scale` (the env and a separately started emulator then agree as long as both use the same factor).
:class:`VirtualClock` only moves when the env waits for its next tick: with the emulator in the same process it
gives a lock-step mode in which every tick lasts exactly one control period whatever the machine load, so
whole episodes run as fast as the round trips allow and tests are deterministic.
"""
from __future__ import annotations

import math
import threading
import time


class RealClock:
    """Monotonic wall time since creation, multiplied by `time_scale` (1 = real time)."""

    def __init__(self, time_scale: float = 1.0) -> None:
        if not (isinstance(time_scale, (int, float)) and math.isfinite(time_scale) and time_scale > 0):
            raise ValueError(f"time_scale must be a positive finite number, got {time_scale!r}")
        self.time_scale = float(time_scale)
        self._t0 = time.monotonic()

    def now(self) -> float:
        return (time.monotonic() - self._t0) * self.time_scale

    def sleep_until(self, t: float) -> None:
        # sleep most of the way, then spin briefly: time.sleep alone overshoots by ~0.1 ms on Linux, which is
        # 3 % of a 3.3 ms tick at time_scale 10
        while True:
            remaining = (t - self.now()) / self.time_scale
            if remaining <= 0:
                return
            if remaining > 0.002:
                time.sleep(remaining - 0.001)
            else:
                time.sleep(0)

    def wall_seconds(self, robot_seconds: float) -> float:
        return robot_seconds / self.time_scale


class VirtualClock:
    """Time that advances only when someone sleeps: ``sleep_until(t)`` jumps to `t` at once.

    Thread-safe: the emulator's server threads read it while the env advances it.
    """

    time_scale = math.inf

    def __init__(self, start: float = 0.0) -> None:
        self._t = float(start)
        self._lock = threading.Lock()

    def now(self) -> float:
        with self._lock:
            return self._t

    def sleep_until(self, t: float) -> None:
        with self._lock:
            if t > self._t:
                self._t = float(t)

    def advance(self, dt: float) -> None:
        with self._lock:
            self._t += float(dt)

    def wall_seconds(self, robot_seconds: float) -> float:
        return 0.0
