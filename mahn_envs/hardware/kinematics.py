"""Differential-drive conversions: motions -> body velocity -> wheel speeds in firmware units, and back.

Units: the env speaks cm/s and rad/s (like the simulator); the firmware takes wheel set points in its own
speed unit, ``units = mm/s * speed_unit``.  K-Team documents 144.01 units per mm/s for motor firmware below 3.0
and 218.72 from 3.0 on; :func:`speed_unit_for_version` picks one from the ``B`` reply (override it when you
know your robots better).  The wheel base (distance between the wheel contact points) defaults to 8.85 cm, the
K-Team manual's 88.5 mm; measured turning rates (60 mm/s per wheel -> ~1.3 rad/s) suggest ~9.2 cm in
practice, so calibrate it by timing a full turn in place (docs/hardware.md).
"""
from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from enum import IntEnum

from ..core.api import TURN_LEFT, TURN_RIGHT, steer

SPEED_UNIT_V3 = 218.72  # firmware units per mm/s, motor firmware >= 3.0
SPEED_UNIT_V2 = 144.01  # below 3.0
WHEEL_BASE_CM = 8.85


class Motion(IntEnum):
    """What the wheels do for one tick."""

    LEFT = 0  # turn left in place
    FORWARD = 1
    RIGHT = 2  # turn right in place
    STOP = 3
    ARC_LEFT = 4  # forward speed while turning left (side reflex while moving)
    ARC_RIGHT = 5

    @property
    def moving(self) -> bool:
        return self in (Motion.FORWARD, Motion.ARC_LEFT, Motion.ARC_RIGHT)

    @classmethod
    def of(cls, turn: int, velocity: float) -> Motion:
        """The motion of the core's (turn, velocity) decision (core.api.steer)."""
        driving = velocity > 0.0
        if turn == TURN_LEFT:
            return cls.ARC_LEFT if driving else cls.LEFT
        if turn == TURN_RIGHT:
            return cls.ARC_RIGHT if driving else cls.RIGHT
        return cls.FORWARD if driving else cls.STOP


def reflex_motion(action: int, proximity: Sequence[float], moving: bool, floor: float = 0.25,
                  enabled: bool = True, arc: bool = False) -> Motion:
    """The simulator's decision (action through the collision-avoidance reflex, ``core.api.steer``) as a
    wheel motion, given the six un-floored [0, 1] sensor values (index 0 leftmost, 1 = free) and whether the
    robot was driving forward.  The reflex keeps the velocity when it turns, so a driving robot arcs round the
    obstacle and a standing one turns in place (with `arc`, the arcing reflex: it arcs too); ``result.moving`` is
    the robot's new state."""
    turn, velocity = steer(action, proximity, 1.0 if moving else 0.0, speed=1.0, floor=floor, reflex=enabled,
                           arc=arc)
    return Motion.of(turn, velocity)


def speed_unit_for_version(version: int, revision: int = 0) -> float:
    """Firmware speed unit (units per mm/s) for the version a ``B`` reply reports."""
    return SPEED_UNIT_V3 if version >= 3 else SPEED_UNIT_V2


@dataclass(frozen=True)
class Drive:
    """Forward speed (cm/s), turn rate (rad/s) and wheel base (cm) of the commanded motions."""

    forward_speed: float
    turn_rate: float
    wheel_base: float = WHEEL_BASE_CM

    def __post_init__(self) -> None:
        for name in ("forward_speed", "turn_rate", "wheel_base"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or v <= 0:
                raise ValueError(f"{name} must be a positive finite number, got {v!r}")
        if self.forward_speed > 30.0:
            raise ValueError(f"forward_speed {self.forward_speed} cm/s exceeds the Khepera III's ~30 cm/s")

    def body(self, motion: Motion) -> tuple[float, float]:
        """(v cm/s, omega rad/s, positive = left) of a motion."""
        v, w = self.forward_speed, self.turn_rate
        return {Motion.FORWARD: (v, 0.0), Motion.LEFT: (0.0, w), Motion.RIGHT: (0.0, -w),
                Motion.STOP: (0.0, 0.0), Motion.ARC_LEFT: (v, w), Motion.ARC_RIGHT: (v, -w)}[Motion(motion)]

    def wheels(self, motion: Motion) -> tuple[float, float]:
        """(left, right) wheel speeds in cm/s."""
        v, w = self.body(motion)
        half = w * self.wheel_base / 2.0
        return v - half, v + half

    def units(self, motion: Motion, speed_unit: float) -> tuple[int, int]:
        """(left, right) set points in firmware units, rounded to the nearest unit."""
        left, right = self.wheels(motion)
        return to_units(left, speed_unit), to_units(right, speed_unit)


def to_units(cm_per_s: float, speed_unit: float) -> int:
    return int(round(cm_per_s * 10.0 * speed_unit))


def from_units(units: int, speed_unit: float) -> float:
    """cm/s of a wheel set point."""
    return units / speed_unit / 10.0


def body_velocity(left_cm_s: float, right_cm_s: float, wheel_base: float) -> tuple[float, float]:
    """(v, omega) of a differential drive with the given wheel speeds."""
    return (left_cm_s + right_cm_s) / 2.0, (right_cm_s - left_cm_s) / wheel_base
