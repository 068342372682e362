"""The simulated Khepera III: one definition shared by every engine, the env and the trainer.

Every number here reproduces the original IROS 2011 simulator (docs/original-system.md), expressed in our
frame (centimetres, seconds, radians, y up, heading counter-clockwise, positive relative angle = left).
Keeping them in one frozen record means the batch core, the pymunk engine, the renderer and the hardware
emulator cannot drift apart.
"""
from __future__ import annotations

from dataclasses import dataclass, field, fields, replace
from typing import Any

import numpy as np

#: Original sensor angles in *screen* coordinates were -1.3398 .. +1.3398 (negative = left).  Mirroring the
#: world (y -> -y) flips the sign, so in our frame index 0 (the leftmost sensor) sits at +1.3398 rad.
_SENSOR_STEP = 0.53592
SENSOR_ANGLES = tuple(1.3398 - j * _SENSOR_STEP for j in range(6))


@dataclass(frozen=True)
class KheperaModel:
    """Physical and control constants of the simulated robot.

    Defaults are the original system's values.  ``dt_robot`` is the float32 rounding of 0.033 that the
    original robot model used for motion; reproducing it keeps trajectories within 1e-10 of the reference.
    """

    radius: float = 6.5
    speed: float = 9.0  # cm/s forward
    turn_rate: float = float(np.float32(6.28 / 3.0))  # rad/s turning in place
    dt: float = 0.033  # s per control tick (the clock)
    ir_range: float = 10.16  # cm of IR range beyond the body surface
    sensor_floor: float = 0.25  # inputs at or below this read 0 ("very close")
    sensor_angles: tuple[float, ...] = field(default=SENSOR_ANGLES)

    def __post_init__(self) -> None:
        for f in fields(self):
            value = getattr(self, f.name)
            if f.name == "sensor_angles":
                arr = np.asarray(value, dtype=float)
                if arr.shape != (6,) or not np.all(np.isfinite(arr)):
                    raise ValueError("KheperaModel.sensor_angles must be 6 finite angles (radians, left first)")
                continue
            if not np.isfinite(value) or value <= 0:
                raise ValueError(f"KheperaModel.{f.name} must be a positive finite number, got {value!r}")

    @property
    def dt_robot(self) -> float:
        return float(np.float32(self.dt))

    @property
    def sensor_range(self) -> float:
        """Ray length measured from the robot centre (body radius plus IR range)."""
        return self.radius + self.ir_range

    @property
    def turn_step(self) -> float:
        """Heading change of one turning tick, rounded to float32 as in the original."""
        return float(np.float32(np.float32(self.dt) * np.float32(self.turn_rate)))

    def with_(self, **changes: Any) -> KheperaModel:
        return replace(self, **changes)


DEFAULT_MODEL = KheperaModel()


# ---------------------------------------------------------------- the real robot's IR sensors
#: a Khepera III IR reading is a 12-bit reflection count that rises as the gap to a wall shrinks
IR_RAW_MAX = 4095
#: the paper's calibration of counts to the simulator's [0, 1] scale: unit = A - (log10(raw) - B) / C, clipped
#: (raw 30 reads 1.0, about 12 cm; raw ~1460 reads 0.25, about 2.6 cm); hardware.calibration.LogCalibration
IR_CALIBRATION_A, IR_CALIBRATION_B, IR_CALIBRATION_C = 1.43, 0.51, 2.25
#: relative noise (Gaussian sigma / count) of a real Khepera III IR reading against the gap in metres, from
#: K-Team's calibration as the Webots model uses it (docs/original-system.md section 12): the emulator's sensors
#: and the core's `sensor_model="khepera"` (TaskParams)
IR_NOISE_GAP_M = np.array([0.0, 0.0135, 0.018, 0.0225, 0.027, 0.0405, 0.0585, 0.0675, 0.0855, 0.1035, 0.153,
                           0.252, 0.4455])
IR_NOISE_SIGMA = np.array([0.0015, 0.10, 0.19, 0.22, 0.23, 0.27, 0.21, 0.15, 0.12, 0.22, 0.52, 0.84, 1.0])
