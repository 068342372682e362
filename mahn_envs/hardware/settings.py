"""The hardware env's settings: one frozen, validated record per concern.

``KheperaHardwareEnv(ports, map=..., driving=..., sensing=..., timing=..., episode=..., poses=..., link=...)``
takes these records instead of two dozen loose keywords, the way the trainer groups its NEAT settings
(``mahn_evo.neat.settings``).  Each record checks its own fields when it is made, with a ValueError that names
the field, so a bad value fails before any robot is contacted, and a run's settings are plain values that can
be kept, compared and changed with ``dataclasses.replace``.  What a record cannot know alone (how many robots
there are, which map) the env checks: a per-robot ``speed_unit`` list, the agents of a ``signal_schedule``, a
``pose_source`` on a map with as many start poses as ports.

Every default reproduces the simulator and the original task.  ``None`` means "the robot model's value"
(``KheperaModel``, the env's ``model=``: 9 cm/s, 2.0933 rad/s, the 0.25 sensor floor, 33 ms ticks), so a team
meets on the robots the numbers it was trained with.
"""
from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Any

import numpy as np

from ..core.params import ORIGINAL_MAX_TICKS, ORIGINAL_SIGNAL_TICK, TaskParams
from ..khepera import KheperaModel
from .calibration import make_calibration
from .clock import RealClock
from .kinematics import WHEEL_BASE_CM, Drive
from .transport import RetryPolicy, open_url

PLACEMENTS = ("prompt", "none")


def _check(cond: bool, record: str, name: str, msg: str) -> None:
    if not cond:
        raise ValueError(f"{record}.{name} {msg}")


def _is_number(v: Any) -> bool:
    return isinstance(v, (int, float, np.integer, np.floating)) and not isinstance(v, (bool, np.bool_))


def _is_count(v: Any) -> bool:
    return isinstance(v, (int, np.integer)) and not isinstance(v, (bool, np.bool_))


def _check_positive(record: str, name: str, v: Any) -> None:
    _check(_is_number(v) and math.isfinite(v) and v > 0, record, name, f"must be a positive finite number, got {v!r}")


def _check_flag(record: str, name: str, v: Any) -> None:
    _check(isinstance(v, (bool, np.bool_)), record, name, f"must be True or False, got {v!r}")


@dataclass(frozen=True)
class Driving:
    """How an action becomes a wheel command: the collision-avoidance reflex, the speeds of "forward" and
    "turn", the wheel base that turns them into wheel speeds, and the firmware's speed unit.

    The original deployment drove at 15049 firmware units (6.88 cm/s forward, about 1.55 rad/s turning) with no
    reflex: ``Driving(forward_speed=6.88, turn_rate=1.55, reflex=False)`` reproduces it.
    """

    #: cm/s of "forward"; None: the model's (9, the simulator's).
    forward_speed: float | None = None
    #: rad/s of turning in place; None: the model's (2.0933, the simulator's).
    turn_rate: float | None = None
    #: cm between the wheel contact points (K-Team's 88.5 mm; calibrate it by timing a turn, docs/hardware.md).
    wheel_base: float = WHEEL_BASE_CM
    #: Firmware units per mm/s: "auto" (from the ``B`` reply: 218.72 for firmware >= 3, 144.01 below), one
    #: number for every robot, or one number per robot.
    speed_unit: str | float | tuple[float, ...] = "auto"
    #: The simulator's collision-avoidance reflex between the action and the wheels (on, as in simulation).
    reflex: bool = True
    #: The arcing reflex (TaskParams.reflex_arc): its side branches drive forward.  Teams evolved with it need it;
    #: `mahn-evo deploy` sets it from the champion file.
    reflex_arc: bool = False

    def __post_init__(self) -> None:
        for name in ("forward_speed", "turn_rate"):
            v = getattr(self, name)
            _check(v is None or _is_number(v), "Driving", name, f"must be a number or None, got {v!r}")
        _check(_is_number(self.wheel_base), "Driving", "wheel_base", f"must be a number, got {self.wheel_base!r}")
        try:  # the limits of a drive are Drive's (kinematics); its messages start with the field's name
            self.drive(KheperaModel())
        except ValueError as exc:
            raise ValueError(f"Driving.{exc}") from None
        unit: Any = self.speed_unit
        if isinstance(unit, str):
            _check(unit == "auto", "Driving", "speed_unit", f"must be 'auto', a number or one number per robot, "
                                                            f"got {unit!r}")
        elif _is_number(unit):
            _check_positive("Driving", "speed_unit", unit)
            object.__setattr__(self, "speed_unit", float(unit))
        else:
            try:
                units = tuple(unit)
            except TypeError:
                raise ValueError(f"Driving.speed_unit must be 'auto', a number or one number per robot, "
                                 f"got {unit!r}") from None
            _check(len(units) > 0, "Driving", "speed_unit", "lists no value")
            for u in units:
                _check_positive("Driving", "speed_unit", u)
            object.__setattr__(self, "speed_unit", tuple(float(u) for u in units))
        _check_flag("Driving", "reflex", self.reflex)
        _check_flag("Driving", "reflex_arc", self.reflex_arc)

    def drive(self, model: KheperaModel) -> Drive:
        """The wheel-speed conversion these settings give on a robot of `model` (None speeds are the model's)."""
        return Drive(model.speed if self.forward_speed is None else float(self.forward_speed),
                     model.turn_rate if self.turn_rate is None else float(self.turn_rate), float(self.wheel_base))


@dataclass(frozen=True)
class Sensing:
    """How raw IR counts become observations: the calibration to the simulator's [0, 1] scale and the floor at
    or below which a value reads 0 (the reflex sees the values before the floor, as in simulation)."""

    #: "paper" (the paper's log formula), "linear" (the original code's ``1 - raw/4000``), an object with
    #: ``to_unit`` (e.g. a ``TableCalibration``) or a function raw -> [0, 1]; kept as the calibration object.
    calibration: Any = "paper"
    #: Observations at or below it read 0; None: the model's (0.25, as in simulation).
    sensor_floor: float | None = None
    #: Observations at or above it read 1 (TaskParams.input_ceiling; 1, the original's, changes nothing).  Teams
    #: evolved with a ceiling need it; `mahn-evo deploy` sets it from the champion file.
    input_ceiling: float = 1.0

    def __post_init__(self) -> None:
        try:
            object.__setattr__(self, "calibration", make_calibration(self.calibration))
        except ValueError as exc:
            raise ValueError(f"Sensing.calibration: {exc}") from None
        v = self.sensor_floor
        _check(v is None or (_is_number(v) and 0.0 <= v < 1.0), "Sensing", "sensor_floor",
               f"must be in [0, 1) or None, got {v!r}")
        try:  # the task's own check of the value (one rule, written once)
            TaskParams(input_ceiling=self.input_ceiling)
        except ValueError as exc:
            raise ValueError(f"Sensing.input_ceiling: {exc}") from None

    def floor(self, model: KheperaModel) -> float:
        return float(model.sensor_floor if self.sensor_floor is None else self.sensor_floor)


@dataclass(frozen=True)
class Timing:
    """The control period and the clock that paces it: real time (optionally sped up by `time_scale`, for an
    emulator started with the same factor) or a given clock (a ``VirtualClock`` shared with an in-process
    emulator runs lock-step)."""

    #: Seconds per tick; None: the model's (0.033).
    period: float | None = None
    #: Robot seconds per wall second of the real-time clock (1 = real time).
    time_scale: float = 1.0
    #: A clock (``now()``, ``sleep_until(t)``) to pace with instead of real time; it sets its own pace, so a
    #: time_scale other than 1 is refused beside it.
    clock: Any = None

    def __post_init__(self) -> None:
        if self.period is not None:
            _check_positive("Timing", "period", self.period)
        _check_positive("Timing", "time_scale", self.time_scale)
        if self.clock is not None:
            _check(callable(getattr(self.clock, "now", None)) and callable(getattr(self.clock, "sleep_until", None)),
                   "Timing", "clock", f"must have now() and sleep_until(t) (see hardware.clock), got {self.clock!r}")
            _check(self.time_scale == 1.0, "Timing", "time_scale",
                   f"must be left at 1 when a clock is given (the clock sets the pace), got {self.time_scale!r}")

    def tick_seconds(self, model: KheperaModel) -> float:
        return float(model.dt if self.period is None else self.period)

    def make_clock(self) -> Any:
        """The given clock, or a real-time clock at `time_scale` starting now."""
        return self.clock if self.clock is not None else RealClock(self.time_scale)


@dataclass(frozen=True)
class Episode:
    """How long an episode lasts and when the come-home signal comes, as in the simulated env, plus extra
    per-robot signals (``env.call_home(agent)`` / ``env.clear_signal(agent)`` give them by hand)."""

    #: Ticks per episode (1364: the original's 45 s of 33 ms ticks).
    max_cycles: int = ORIGINAL_MAX_TICKS
    #: Tick of the automatic come-home signal (690, the original's first fitness sample past half time).
    signal_tick: int = ORIGINAL_SIGNAL_TICK
    #: Give every robot the signal at `signal_tick`.
    auto_signal: bool = True
    #: {agent: tick}: more scheduled signals, one robot each (kept read-only).
    signal_schedule: Mapping[str, int] = field(default_factory=dict)

    def __post_init__(self) -> None:
        for name in ("max_cycles", "signal_tick"):
            v = getattr(self, name)
            _check(_is_count(v) and v >= 1, "Episode", name, f"must be a positive integer, got {v!r}")
        _check_flag("Episode", "auto_signal", self.auto_signal)
        try:  # the task's own rules on these (the signal comes at a fitness sample) are TaskParams'
            self.task_params()
        except ValueError as exc:
            raise ValueError(f"Episode: {exc}") from None
        schedule = self.signal_schedule
        _check(isinstance(schedule, Mapping), "Episode", "signal_schedule",
               f"must be a dict {{agent: tick}}, got {schedule!r}")
        for agent, tick in schedule.items():
            _check(isinstance(agent, str) and bool(agent), "Episode", "signal_schedule",
                   f"keys must be agent names, got {agent!r}")
            _check(_is_count(tick) and tick >= 1, "Episode", "signal_schedule",
                   f"tick for {agent!r} must be a positive integer, got {tick!r}")
        object.__setattr__(self, "signal_schedule", MappingProxyType({a: int(t) for a, t in schedule.items()}))

    def task_params(self) -> TaskParams:
        """The task's settings for scoring this episode (the original's in every other respect)."""
        return TaskParams(max_cycles=int(self.max_cycles), signal_tick=int(self.signal_tick),
                          auto_signal=bool(self.auto_signal))


@dataclass(frozen=True)
class Poses:
    """Where the robots are: how they get to their start poses before an episode, and (optionally) an overhead
    tracker that reports their poses, with which the env scores the run with the simulator's fitness code."""

    #: "prompt" (print the start poses and wait for Enter; needs a terminal), "none" (they are in place), or a
    #: function {agent: (x, y, heading) or None} -> None that places them.
    placement: str | Callable[[dict], None] = "prompt"
    #: A function returning the robots' (x, y, heading) in the map frame, as an (n, 3) array or {agent: pose};
    #: enables rewards, ``team_fitness`` / ``solved``, ``infos['pose']`` and rendering.  None: no tracking.
    pose_source: Callable[[], Any] | None = None

    def __post_init__(self) -> None:
        p = self.placement
        _check(callable(p) or (isinstance(p, str) and p in PLACEMENTS), "Poses", "placement",
               f"must be 'prompt', 'none' or a function {{agent: pose}} -> None, got {p!r}")
        _check(self.pose_source is None or callable(self.pose_source), "Poses", "pose_source",
               f"must be a function returning the robots' (x, y, heading), got {self.pose_source!r}")


@dataclass(frozen=True)
class Link:
    """The line to each robot: the retry policy (timeouts, attempts, reopenings), the serial settings, and the
    function that opens a URL (pyserial's, replaceable for other transports)."""

    #: Timeout per attempt, attempts per command, reopenings of a dropped link (0.12 s x 3 detects a silent
    #: robot within 0.5 s).
    retry: RetryPolicy = RetryPolicy()
    #: Line speed of kh3server (115200 8N1).
    baudrate: int = 115200
    #: End of every command line.
    eol: str = "\n"
    #: ``opener(url, read_timeout, baudrate)`` -> an open port (pyserial's ``serial_for_url`` by default).
    opener: Callable[[str, float, int], Any] = open_url

    def __post_init__(self) -> None:
        _check(isinstance(self.retry, RetryPolicy), "Link", "retry", f"must be a RetryPolicy, got {self.retry!r}")
        _check(_is_count(self.baudrate) and self.baudrate > 0, "Link", "baudrate",
               f"must be a positive integer, got {self.baudrate!r}")
        _check(isinstance(self.eol, str) and bool(self.eol), "Link", "eol",
               f"must be a non-empty string (a line end), got {self.eol!r}")
        _check(callable(self.opener), "Link", "opener", f"must be a function (url, timeout, baudrate) -> port, "
                                                         f"got {self.opener!r}")


__all__ = ["Driving", "Sensing", "Timing", "Episode", "Poses", "Link"]
