"""The collision-avoidance reflex as a pure function, for the hardware env.

The simulator applies the reflex inside ``core.task.decide_robot`` by changing heading and velocity; a real
robot needs a wheel command instead.  This is the same rule with the same branch order, expressed as a
:class:`Motion` (tests/hardware/test_reflex.py pins it to ``decide_robot`` on identical inputs):

forward asked and
  a. left sensor 0 or 1 at or below the floor  -> turn right, keeping the current velocity
  b. else front sensor 2 or 3 at or below       -> stop (no turn)
  c. else right sensor 4 or 5 at or below       -> turn left, keeping the current velocity
  d. else                                       -> forward
left / right asked -> turn in place.

"Keeping the velocity" is the original's quirk: a robot that was driving arcs round the obstacle, one that was
turning or blocked turns in place.  So the reflex needs one bit of state, ``moving``, returned updated.
Comparisons are float32 like the simulator's.
"""
from __future__ import annotations

from collections.abc import Sequence
from enum import IntEnum

import numpy as np

LEFT, FORWARD, RIGHT = 0, 1, 2


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


def reflex_motion(action: int, proximity: Sequence[float], moving: bool, floor: float = 0.25,
                  enabled: bool = True) -> Motion:
    """Wheel motion for `action` (0 left, 1 forward, 2 right) given the six un-floored [0, 1] sensor values
    (index 0 leftmost, 1 = free) and whether the robot was moving forward.  ``result.moving`` is the new state.
    """
    if action == LEFT:
        return Motion.LEFT
    if action == RIGHT:
        return Motion.RIGHT
    if action != FORWARD:
        raise ValueError(f"action must be 0 (left), 1 (forward) or 2 (right), got {action!r}")
    if len(proximity) != 6:
        raise ValueError(f"the reflex needs the six front sensor values, got {len(proximity)}")
    if enabled:
        q = np.asarray(proximity, dtype=np.float32)
        f = np.float32(floor)
        if q[0] <= f or q[1] <= f:
            return Motion.ARC_RIGHT if moving else Motion.RIGHT
        if q[2] <= f or q[3] <= f:
            return Motion.STOP
        if q[4] <= f or q[5] <= f:
            return Motion.ARC_LEFT if moving else Motion.LEFT
    return Motion.FORWARD
