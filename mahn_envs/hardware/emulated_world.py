"""The robots the emulator pretends to be: simulator geometry, wheel-speed motion in (robot) time, IR counts.

Motion: each robot drives with the wheel speeds of its last ``D`` command (converted with the firmware speed
unit and the wheel base), integrated exactly along arcs in sub-steps of at most `max_substep` seconds from
the last time anyone looked to the clock's "now".  A sub-step that would touch a wall is undone (heading kept),
the simulator's revert-on-collision rule.  Robots pass through each other, as in the simulator.

Sensing: the same ray casts as the simulator (``core.api.Arena.ranges``, the model's six sensor angles for
ring sensors 1-6, +-129 deg and 180 deg for the back ones), turned into the simulator's un-floored unit value
(gap / IR range), then into counts through the calibration's inverse, with the real sensor's relative Gaussian
noise (K-Team's calibration table), rounded and capped to 12 bits.  Floor sensors read a constant.
"""
from __future__ import annotations

import math
import threading
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..core.api import Arena
from ..khepera import DEFAULT_MODEL, KheperaModel
from ..maps import World, load_map
from .calibration import PAPER, RAW_MAX, make_calibration, relative_noise
from .clock import RealClock
from .kinematics import SPEED_UNIT_V3, WHEEL_BASE_CM, body_velocity, from_units

BACK_ANGLES = (math.radians(129.0), math.radians(-129.0), math.pi)  # ring sensors 0, 7, 8
FLOOR_IR = 900  # what the two floor sensors read on a light floor (unused by the task)


@dataclass
class RobotState:
    pose: np.ndarray  # x, y, heading
    left: int = 0  # wheel set points, firmware units
    right: int = 0
    motors_on: bool = False
    last_command: float = 0.0  # robot time of the last command received
    stamp0: float = 0.0  # robot time of the last Z (timestamp origin)
    collisions: int = 0
    rng: np.random.Generator = field(default_factory=np.random.default_rng)


class EmulatedWorld:
    """Robots on a map, moved in real (or scaled, or virtual) time from their wheel set points.

    Thread-safe: every public method takes the world lock, so one server thread per robot can share it.
    """

    def __init__(self, map: str | World = "plus", n_robots: int | None = None, *, clock: Any = None,
                 model: KheperaModel = DEFAULT_MODEL, wheel_base: float = WHEEL_BASE_CM,
                 speed_unit: float = SPEED_UNIT_V3, firmware: tuple[int, int] = (3, 0), calibration: Any = PAPER,
                 noise: float = 1.0, seed: int = 0, robots_see_each_other: bool = False,
                 max_substep: float = 0.005, watchdog: float | None = None,
                 motors_need_init: bool = True) -> None:
        self.world = load_map(map)
        n = self.world.n_robots if n_robots is None else int(n_robots)
        if n < 1 or n > self.world.n_robots:
            raise ValueError(f"map {self.world.name!r} has {self.world.n_robots} start poses; cannot emulate {n}")
        if not (noise >= 0):
            raise ValueError(f"noise must be >= 0 (1 = a real robot's), got {noise!r}")
        if watchdog is not None and not watchdog > 0:
            raise ValueError(f"watchdog must be a positive number of seconds or None, got {watchdog!r}")
        self.n_robots = n
        self.clock = clock if clock is not None else RealClock()
        self.model = model
        self.wheel_base = float(wheel_base)
        self.speed_unit = float(speed_unit)
        self.firmware = (int(firmware[0]), int(firmware[1]))
        self.calibration = make_calibration(calibration)
        self.noise = float(noise)
        self.robots_see_each_other = bool(robots_see_each_other)
        self.max_substep = float(max_substep)
        self.watchdog = watchdog
        self.motors_need_init = motors_need_init
        # the simulator's geometry, with the firmware's ring of nine IR sensors: back-left, the task's six
        # (left to right), back-right, back
        a = model.sensor_angles
        self.arena = Arena(self.world, model, sensor_angles=[BACK_ANGLES[0], *a, BACK_ANGLES[1], BACK_ANGLES[2]])
        # compiled before serving: a robot's first command must not wait for a compilation (Arena.compile_rules)
        self.arena.compile_rules()
        self._lock = threading.RLock()
        now = self.clock.now()
        self.time = now
        self.robots = [RobotState(pose=self.world.starts[k].copy(), last_command=now, stamp0=now,
                                  motors_on=not motors_need_init,
                                  rng=np.random.default_rng([int(seed) & 0xFFFFFFFF, k]))
                       for k in range(n)]

    # ------------------------------------------------------------------ time
    def advance(self, now: float | None = None) -> None:
        """Move every robot from the last update to `now` (default: the clock's now)."""
        with self._lock:
            t1 = self.clock.now() if now is None else float(now)
            t0 = self.time
            if t1 <= t0:
                return
            for rob in self.robots:
                start = t0
                if self.watchdog is not None and rob.left | rob.right:
                    cutoff = rob.last_command + self.watchdog
                    if cutoff <= t0:
                        rob.left = rob.right = 0
                    elif cutoff < t1:
                        self._move(rob, t0, cutoff)
                        rob.left = rob.right = 0
                        start = cutoff
                self._move(rob, start, t1)
            self.time = t1

    def _move(self, rob: RobotState, t0: float, t1: float) -> None:
        if not rob.motors_on or (rob.left == 0 and rob.right == 0) or t1 <= t0:
            return
        v, w = body_velocity(from_units(rob.left, self.speed_unit), from_units(rob.right, self.speed_unit),
                             self.wheel_base)
        n = max(1, math.ceil((t1 - t0) / self.max_substep - 1e-9))
        h = (t1 - t0) / n
        x, y, th = float(rob.pose[0]), float(rob.pose[1]), float(rob.pose[2])
        for _ in range(n):
            th1 = th + w * h
            if abs(w) < 1e-12:
                nx, ny = x + v * h * math.cos(th), y + v * h * math.sin(th)
            else:
                nx = x + v / w * (math.sin(th1) - math.sin(th))
                ny = y - v / w * (math.cos(th1) - math.cos(th))
            if v != 0.0:  # the simulator's wall rule: a sub-step that would touch a wall is undone
                x, y, touched = self.arena.move(x, y, nx, ny)
                rob.collisions += touched
            th = th1
        rob.pose[:] = (x, y, th)

    # ------------------------------------------------------------------ commands
    def command_received(self, k: int) -> float:
        """Note that robot k heard a command (the watchdog's heartbeat); returns the robot time."""
        with self._lock:
            self.advance()
            self.robots[k].last_command = self.time
            return self.time

    def init_motors(self, k: int) -> None:
        with self._lock:
            self.advance()
            self.robots[k].motors_on = True

    def set_speeds(self, k: int, left: int, right: int) -> None:
        with self._lock:
            self.advance()
            rob = self.robots[k]
            rob.left, rob.right = int(left), int(right)

    def speeds(self, k: int) -> tuple[int, int]:
        with self._lock:
            self.advance()
            rob = self.robots[k]
            return (rob.left, rob.right) if rob.motors_on else (0, 0)

    def reset_timestamp(self, k: int) -> None:
        with self._lock:
            self.advance()
            self.robots[k].stamp0 = self.time

    def timestamp(self, k: int) -> int:
        """Milliseconds since the last ``Z``, as an unsigned 32-bit counter."""
        return int((self.time - self.robots[k].stamp0) * 1000.0) & 0xFFFFFFFF

    # ------------------------------------------------------------------ sensing
    def proximity(self, k: int) -> list[int]:
        """The 11 raw values of an ``N`` reply for robot k, now."""
        with self._lock:
            self.advance()
            rob = self.robots[k]
            others = None
            if self.robots_see_each_other:
                others = np.array([other.pose[:2] for q, other in enumerate(self.robots) if q != k]).reshape(-1, 2)
            rays = self.arena.ranges(float(rob.pose[0]), float(rob.pose[1]), float(rob.pose[2]), others)
            gap = rays - self.model.radius
            raw = np.asarray(self.calibration.to_raw(gap / self.model.ir_range), dtype=np.float64)
            if self.noise > 0:
                sigma = self.noise * relative_noise(np.maximum(gap, 0.0))
                raw = raw * (1.0 + sigma * rob.rng.standard_normal(raw.shape))
                floor = FLOOR_IR * (1.0 + 0.02 * self.noise * rob.rng.standard_normal(2))
            else:
                floor = np.full(2, float(FLOOR_IR))
            vals = np.clip(np.rint(np.concatenate([raw, floor])), 0, RAW_MAX).astype(int)
            return [int(v) for v in vals]

    def ambient(self, k: int) -> list[int]:
        """``O`` reply values: a dim, steady room (the task never reads them)."""
        with self._lock:
            rob = self.robots[k]
            base = np.full(11, 3900.0)
            if self.noise > 0:
                base += 20.0 * self.noise * rob.rng.standard_normal(11)
            return [int(v) for v in np.clip(np.rint(base), 0, RAW_MAX)]

    # ------------------------------------------------------------------ the "overhead camera"
    def poses(self) -> np.ndarray:
        """(n_robots, 3) x, y, heading now: a perfect external tracker, for tests and deploy logs."""
        with self._lock:
            self.advance()
            return np.array([r.pose for r in self.robots])

    def place(self, poses: Mapping[Any, Sequence[float]] | Sequence[Sequence[float]] | np.ndarray) -> None:
        """Put robots at poses (what the operator does by hand).  Keys may be indices or 'robot_k' names."""
        with self._lock:
            self.advance()
            items = poses.items() if isinstance(poses, Mapping) else enumerate(poses)
            for key, pose in items:
                k = int(str(key).rsplit("_", 1)[-1]) if isinstance(key, str) else int(key)
                if not 0 <= k < self.n_robots:
                    raise ValueError(f"no emulated robot {key!r}")
                if pose is None:
                    continue
                p = np.asarray(pose, dtype=np.float64)
                if p.shape != (3,) or not np.all(np.isfinite(p)):
                    raise ValueError(f"pose for robot {key!r} must be finite (x, y, heading), got {pose!r}")
                self.robots[k].pose[:] = p

    def stopped(self, k: int) -> bool:
        with self._lock:
            rob = self.robots[k]
            return rob.left == 0 and rob.right == 0
