"""Task settings: the original task by default, plus the noise levels of the generalisation test."""
from __future__ import annotations

import math
from dataclasses import asdict, dataclass, fields, replace
from typing import Any

import numpy as np

from ..khepera import DEFAULT_MODEL, KheperaModel
from . import task as T

#: Episode length and signal tick of the original: 45 s of 0.033 s ticks, sampled every floor(1/dt) ticks,
#: signal at the first sample past half time.
ORIGINAL_MAX_TICKS = 1364
ORIGINAL_SIGNAL_TICK = 690
ORIGINAL_SAMPLE_PERIOD = 30


def check_flag(value: object, field: str) -> bool:
    """A switch must be a real boolean: the string 'no' is truthy, so accepting it would turn the switch on."""
    if not isinstance(value, (bool, np.bool_)):
        raise TypeError(f"{field} must be True or False, got {value!r} of type {type(value).__name__}")
    return bool(value)


#: the task's noise levels: IR sensors, effectors (speed and turn rate), heading per tick, start position and heading
NOISE_FIELDS = ("sensor_noise", "effector_noise", "heading_noise", "start_jitter_xy", "start_jitter_heading")


#: the task fields that belong to a team rather than to a test: how its inputs are encoded and how the reflex
#: changes its actions.  A team is evolved with them, so every evaluation of it (eval, generalisation, transfer
#: tests, deploy on robots) must drive it with the same values; champion files record them.
TEAM_FIELDS = ("reflex_arc", "input_ceiling")


@dataclass(frozen=True)
class TaskParams:
    """Episode timing, noise and rule switches.  Every default reproduces the original system.

    Noise levels: `sensor_noise` and `effector_noise` are percentages as in the original (an IR input gets
    +-sensor_noise/100 uniform; speed and turn rate are scaled by 1 +- effector_noise/100 every tick);
    `heading_noise` is a uniform per-tick heading perturbation of at most that many radians;
    `start_jitter_xy` (cm, uniform in a square) and `start_jitter_heading` (rad, uniform) move the start poses.
    """

    max_cycles: int = ORIGINAL_MAX_TICKS
    signal_tick: int = ORIGINAL_SIGNAL_TICK
    sample_period: int = ORIGINAL_SAMPLE_PERIOD
    sensor_noise: float = 0.0
    effector_noise: float = 0.0
    heading_noise: float = 0.0
    start_jitter_xy: float = 0.0
    start_jitter_heading: float = 0.0
    robots_see_each_other: bool = False
    reflex: bool = True
    #: beyond the original: the reflex's side branches drive at speed (the robot arcs away from the wall) instead
    #: of keeping the velocity, so a standing robot asked to go forward beside a wall moves (core.task.steer)
    reflex_arc: bool = False
    auto_signal: bool = True
    #: beyond the original: a sensor value at or above it is read as 1 (open), so the sensor noise cannot move the
    #: input of a ray that sees nothing near (an open ray reads exactly 1 without noise, and within +-noise of 1
    #: with it); 1 is the original's encoding, where it changes nothing (core.task.input_value)
    input_ceiling: float = 1.0
    #: beyond the original: the collision-avoidance reflex reads the sensor values with the sensor noise (what the
    #: network saw this tick, before the cap and the floor), as a real robot's reflex reads its own sensors; the
    #: original's simulated reflex reads the noise-free rays, so teams evolved with sensor noise never meet a reflex
    #: that noise can trip (docs/results/emulator_check/).  Changes nothing without sensor noise.
    reflex_reads_noise: bool = False
    #: beyond the original: how a ray becomes a sensor value (core.task.SENSOR_MODELS).  "uniform" (the original's):
    #: gap / IR range +- sensor_noise/100 uniform.  "khepera": a real Khepera III IR sensor as the emulator makes
    #: one, a 12-bit count by the paper's calibration with Gaussian noise of sensor_noise/100 times a real sensor's
    #: relative noise at that gap (100 = a real sensor), rounded and calibrated back (core.task.khepera_unit)
    sensor_model: str = "uniform"

    def __post_init__(self) -> None:
        for name in ("max_cycles", "signal_tick", "sample_period"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 1:
                raise ValueError(f"TaskParams.{name} must be a positive integer, got {value!r}")
        for name in NOISE_FIELDS:
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, float, np.floating, np.integer)) \
                    or not math.isfinite(value) or value < 0:
                raise ValueError(f"TaskParams.{name} must be a finite number >= 0, got {value!r}")
        for name in ("robots_see_each_other", "reflex", "reflex_arc", "auto_signal", "reflex_reads_noise"):
            check_flag(getattr(self, name), f"TaskParams.{name}")
        if self.sensor_model not in T.SENSOR_MODELS:
            raise ValueError(f"TaskParams.sensor_model must be one of {T.SENSOR_MODELS}, got {self.sensor_model!r}")
        c = self.input_ceiling
        if isinstance(c, bool) or not isinstance(c, (int, float, np.floating, np.integer)) or not math.isfinite(c) \
                or not 0.5 <= c <= 1.0:
            raise ValueError(f"TaskParams.input_ceiling must be a number in [0.5, 1] (1: the original's encoding), "
                             f"got {c!r}")
        if self.effector_noise >= 100:
            raise ValueError("TaskParams.effector_noise must be below 100 (percent), or robots would reverse")
        if self.signal_tick % self.sample_period != 0:
            raise ValueError(f"TaskParams.signal_tick ({self.signal_tick}) must be a multiple of sample_period "
                             f"({self.sample_period}): the signal is given at a fitness sample")

    def to_dict(self) -> dict:
        return asdict(self)

    def without_noise(self) -> TaskParams:
        """The same task with every noise level (sensor, effector, heading, start jitter) at 0, the original's
        sensors and the reflex reading the rays (the sensor model and reflex_reads_noise belong to the noise)."""
        zeros: dict[str, Any] = {name: 0.0 for name in NOISE_FIELDS}
        return replace(self, reflex_reads_noise=False, sensor_model="uniform", **zeros)

    def only_noise(self, name: str) -> TaskParams:
        """The same task with one noise level (a NOISE_FIELDS name) kept and the others at 0: which part of the
        noise a team fails under (`mahn-evo eval --noise-parts`)."""
        if name not in NOISE_FIELDS:
            raise ValueError(f"unknown noise level {name!r}; choose one of {NOISE_FIELDS}")
        kept: dict[str, Any] = {name: getattr(self, name)}
        if name == "sensor_noise":  # the sensors' model, and whether the reflex reads their noise
            kept["reflex_reads_noise"] = self.reflex_reads_noise
            kept["sensor_model"] = self.sensor_model
        return replace(self.without_noise(), **kept)

    @classmethod
    def from_mapping(cls, data: dict) -> TaskParams:
        names = {f.name for f in fields(cls)}
        unknown = set(data) - names
        if unknown:
            raise ValueError(f"unknown task parameter(s) {sorted(unknown)}; known: {sorted(names)}")
        return cls(**data)

    def team_settings(self) -> dict[str, Any]:
        """The fields a team is evolved with and must be driven with wherever it runs (TEAM_FIELDS)."""
        return {name: getattr(self, name) for name in TEAM_FIELDS}

    def with_team_settings(self, settings: TaskParams | dict[str, Any]) -> TaskParams:
        """This task with the team settings of `settings` (a TaskParams or a mapping of TEAM_FIELDS)."""
        values = settings.team_settings() if isinstance(settings, TaskParams) else dict(settings)
        unknown = set(values) - set(TEAM_FIELDS)
        if unknown:
            raise ValueError(f"not team settings: {sorted(unknown)}; team settings are {TEAM_FIELDS}")
        return replace(self, **values)

    def vector(self, model: KheperaModel = DEFAULT_MODEL) -> np.ndarray:
        """The float64 parameter vector the compiled kernels read (indices in core.task)."""
        v = np.zeros(T.N_PARAMS, dtype=np.float64)
        v[T.P_RADIUS] = model.radius
        v[T.P_SPEED] = model.speed
        v[T.P_TURN] = model.turn_rate
        v[T.P_DT] = model.dt_robot
        v[T.P_IR] = model.ir_range
        v[T.P_RANGE] = model.sensor_range
        v[T.P_FLOOR] = model.sensor_floor
        v[T.P_SNOISE] = self.sensor_noise
        v[T.P_ENOISE] = self.effector_noise
        v[T.P_HNOISE] = self.heading_noise
        v[T.P_MAXT] = self.max_cycles
        v[T.P_PERIOD] = self.sample_period
        v[T.P_SIGT] = self.signal_tick
        v[T.P_SEE] = 1.0 if self.robots_see_each_other else 0.0
        v[T.P_AUTOSIG] = 1.0 if self.auto_signal else 0.0
        v[T.P_REFLEX] = (2.0 if self.reflex_arc else 1.0) if self.reflex else 0.0
        v[T.P_CEIL] = self.input_ceiling
        v[T.P_RNOISE] = 1.0 if self.reflex_reads_noise else 0.0
        v[T.P_SMODEL] = float(T.SENSOR_MODELS.index(self.sensor_model))
        return v
