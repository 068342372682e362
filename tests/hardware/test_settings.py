"""The hardware env's settings records: defaults that reproduce the simulator, validation that names the field,
frozen values, the checks only the env can make, and how ``mahn-evo deploy``'s flags fill the records."""
from __future__ import annotations

import argparse
import dataclasses
import math

import pytest

from mahn_envs.core.params import ORIGINAL_MAX_TICKS, ORIGINAL_SIGNAL_TICK, TaskParams
from mahn_envs.hardware import (
    Driving,
    Episode,
    KheperaHardwareEnv,
    LinearCalibration,
    Link,
    LogCalibration,
    Poses,
    RealClock,
    RetryPolicy,
    Sensing,
    Timing,
    VirtualClock,
)
from mahn_envs.hardware.kinematics import WHEEL_BASE_CM, Drive
from mahn_envs.hardware.transport import open_url
from mahn_envs.khepera import DEFAULT_MODEL, KheperaModel
from mahn_evo.deploy import _env_kwargs, add_deploy_parser, deploy

from .test_transport import FakePort


def test_defaults_reproduce_the_simulator_and_the_original_task():
    assert Driving().drive(DEFAULT_MODEL) == Drive(9.0, DEFAULT_MODEL.turn_rate, WHEEL_BASE_CM)
    assert Driving().speed_unit == "auto" and Driving().reflex is True
    assert Sensing().calibration == LogCalibration() and Sensing().floor(DEFAULT_MODEL) == 0.25
    assert Timing().tick_seconds(DEFAULT_MODEL) == 0.033
    assert isinstance(Timing().make_clock(), RealClock) and Timing().make_clock().time_scale == 1.0
    assert (Episode().max_cycles, Episode().signal_tick) == (ORIGINAL_MAX_TICKS, ORIGINAL_SIGNAL_TICK) == (1364, 690)
    assert Episode().task_params() == TaskParams() and dict(Episode().signal_schedule) == {}
    assert Poses() == Poses(placement="prompt", pose_source=None)
    assert Link() == Link(retry=RetryPolicy(), baudrate=115200, eol="\n", opener=open_url)


def test_none_means_the_robot_models_value():
    model = KheperaModel(speed=6.0, turn_rate=1.5, sensor_floor=0.1, dt=0.05)
    assert Driving().drive(model) == Drive(6.0, 1.5, WHEEL_BASE_CM)
    assert Driving(forward_speed=7.0).drive(model) == Drive(7.0, 1.5, WHEEL_BASE_CM)
    assert Sensing().floor(model) == 0.1 and Sensing(sensor_floor=0.0).floor(model) == 0.0
    assert Timing().tick_seconds(model) == 0.05 and Timing(period=0.04).tick_seconds(model) == 0.04


BAD = [
    (Driving, {"forward_speed": -1.0}, "Driving.forward_speed"),
    (Driving, {"forward_speed": 40.0}, "Driving.forward_speed"),  # faster than a Khepera III drives
    (Driving, {"turn_rate": "fast"}, "Driving.turn_rate"),
    (Driving, {"turn_rate": math.nan}, "Driving.turn_rate"),
    (Driving, {"wheel_base": 0.0}, "Driving.wheel_base"),
    (Driving, {"speed_unit": "manual"}, "Driving.speed_unit"),
    (Driving, {"speed_unit": -2.0}, "Driving.speed_unit"),
    (Driving, {"speed_unit": [100.0, 0.0]}, "Driving.speed_unit"),
    (Driving, {"speed_unit": []}, "Driving.speed_unit"),
    (Driving, {"speed_unit": True}, "Driving.speed_unit"),
    (Driving, {"reflex": "no"}, "Driving.reflex"),
    (Sensing, {"calibration": "magic"}, "Sensing.calibration"),
    (Sensing, {"calibration": 5}, "Sensing.calibration"),
    (Sensing, {"sensor_floor": 1.0}, "Sensing.sensor_floor"),
    (Sensing, {"sensor_floor": -0.1}, "Sensing.sensor_floor"),
    (Sensing, {"sensor_floor": "low"}, "Sensing.sensor_floor"),
    (Timing, {"period": 0.0}, "Timing.period"),
    (Timing, {"period": math.inf}, "Timing.period"),
    (Timing, {"time_scale": 0}, "Timing.time_scale"),
    (Timing, {"time_scale": math.nan}, "Timing.time_scale"),
    (Timing, {"clock": object()}, "Timing.clock"),
    (Timing, {"clock": VirtualClock(), "time_scale": 4.0}, "Timing.time_scale"),  # the clock sets the pace
    (Episode, {"max_cycles": 0}, "Episode.max_cycles"),
    (Episode, {"max_cycles": 100.0}, "Episode.max_cycles"),
    (Episode, {"max_cycles": True}, "Episode.max_cycles"),
    (Episode, {"signal_tick": -30}, "Episode.signal_tick"),
    (Episode, {"signal_tick": 100}, "signal_tick"),  # not at a fitness sample (every 30 ticks)
    (Episode, {"auto_signal": 1}, "Episode.auto_signal"),
    (Episode, {"signal_schedule": [("robot_0", 5)]}, "Episode.signal_schedule"),
    (Episode, {"signal_schedule": {"robot_0": 0}}, "Episode.signal_schedule"),
    (Episode, {"signal_schedule": {0: 5}}, "Episode.signal_schedule"),
    (Poses, {"placement": "sometimes"}, "Poses.placement"),
    (Poses, {"placement": None}, "Poses.placement"),
    (Poses, {"pose_source": [[0, 0, 0]]}, "Poses.pose_source"),
    (Link, {"retry": {"timeout": 0.2}}, "Link.retry"),
    (Link, {"baudrate": 0}, "Link.baudrate"),
    (Link, {"baudrate": 9600.5}, "Link.baudrate"),
    (Link, {"eol": ""}, "Link.eol"),
    (Link, {"opener": "serial"}, "Link.opener"),
]


@pytest.mark.parametrize("record, kwargs, field", BAD, ids=[f"{r.__name__}-{next(iter(k))}-{i}"
                                                            for i, (r, k, _) in enumerate(BAD)])
def test_a_bad_value_is_a_value_error_naming_the_field(record, kwargs, field):
    with pytest.raises(ValueError, match=field.replace(".", r"\.")):
        record(**kwargs)


def test_good_values_are_kept_normalised_and_frozen():
    d = Driving(forward_speed=6.88, turn_rate=1.55, wheel_base=9.2, speed_unit=[100, 200.5], reflex=False)
    assert d.speed_unit == (100.0, 200.5) and Driving(speed_unit=150).speed_unit == 150.0
    assert d.drive(DEFAULT_MODEL) == Drive(6.88, 1.55, 9.2)
    assert Sensing(calibration="linear").calibration == LinearCalibration()
    schedule = {"robot_2": 5}
    e = Episode(max_cycles=40, signal_tick=30, auto_signal=False, signal_schedule=schedule)
    schedule["robot_2"] = 9  # the record keeps its own copy ...
    assert dict(e.signal_schedule) == {"robot_2": 5}
    with pytest.raises(TypeError):
        e.signal_schedule["robot_2"] = 9  # ... read-only
    with pytest.raises(dataclasses.FrozenInstanceError):
        e.max_cycles = 10
    assert dataclasses.replace(e, max_cycles=60).max_cycles == 60
    clock = VirtualClock()
    assert Timing(clock=clock).make_clock() is clock and Timing(time_scale=4).make_clock().time_scale == 4.0


def _fake_opener(url, timeout, baudrate):
    return FakePort([b"b,3,0\r\n", b"m\r\n", b"d\r\n", b"d\r\n"], timeout)  # B, M, the stop, the stop at close


def test_the_env_takes_the_records_and_checks_what_only_it_knows():
    env = KheperaHardwareEnv(["fake://0"], map="plus", timing=Timing(time_scale=4), poses=Poses(placement="none"),
                             link=Link(opener=_fake_opener), catch_sigterm=False)
    try:
        assert env.clock.time_scale == 4.0 and env.period == 0.033 and env.max_cycles == 1364
        assert env.speed_units == [218.72] and env.sensor_floor == 0.25 and env.reflex is True
    finally:
        env.close()
    assert env.last_stop_report == {"robot_0": None}
    # checked before any port is opened: no opener is ever called
    with pytest.raises(ValueError, match=r"Driving\.speed_unit lists 2 values for 1 robots"):
        KheperaHardwareEnv(["fake://0"], driving=Driving(speed_unit=[100.0, 200.0]), link=Link(opener=_fail))
    with pytest.raises(ValueError, match=r"Episode\.signal_schedule names unknown agent 'robot_3'"):
        KheperaHardwareEnv(["fake://0"], episode=Episode(signal_schedule={"robot_3": 5}), link=Link(opener=_fail))
    with pytest.raises(TypeError, match="timing must be a Timing record"):
        KheperaHardwareEnv(["fake://0"], timing={"time_scale": 4}, link=Link(opener=_fail))
    with pytest.raises(ValueError, match="scoring needs one robot per start pose"):
        KheperaHardwareEnv(["fake://0"], poses=Poses(pose_source=lambda: [[0.0, 0.0, 0.0]]), link=Link(opener=_fail))


def _fail(url, timeout, baudrate):
    raise AssertionError("a settings error must be found before any port is opened")


def _deploy_args(*flags: str) -> argparse.Namespace:
    parser = argparse.ArgumentParser()
    add_deploy_parser(parser.add_subparsers())
    return parser.parse_args(["deploy", "champion.json", *flags])


def test_deploy_flags_fill_the_records_and_default_to_their_defaults():
    kw = _env_kwargs(_deploy_args("--ports", "/dev/rfcomm0"))
    assert kw["driving"] == Driving() and kw["sensing"] == Sensing() and kw["episode"] == Episode()
    assert kw["timing"] == Timing() and kw["link"] == Link() and "poses" not in kw and kw["map"] is None
    kw = _env_kwargs(_deploy_args("--emulate", "--map", "h", "--max-cycles", "90", "--signal-tick", "60",
                                  "--no-auto-signal", "--placement", "none", "--time-scale", "3",
                                  "--forward-speed", "6.88", "--turn-rate", "1.55", "--wheel-base", "9.2",
                                  "--speed-unit", "150", "--calibration", "linear", "--no-reflex",
                                  "--timeout", "0.3", "--attempts", "2"))
    assert kw["map"] == "h" and kw["episode"] == Episode(max_cycles=90, signal_tick=60, auto_signal=False)
    assert kw["poses"] == Poses(placement="none") and kw["timing"] == Timing(time_scale=3.0)
    assert kw["driving"] == Driving(forward_speed=6.88, turn_rate=1.55, wheel_base=9.2, speed_unit=150.0,
                                    reflex=False)
    assert kw["sensing"] == Sensing(calibration="linear")
    assert kw["link"] == Link(retry=RetryPolicy(timeout=0.3, attempts=2))


def test_deploy_takes_its_clock_once(tmp_path):
    with pytest.raises(ValueError, match="pass the clock to deploy"):
        deploy(tmp_path / "c.json", emulate=True, env_kwargs={"timing": Timing(clock=VirtualClock())})
    with pytest.raises(ValueError, match="not both"):
        deploy(tmp_path / "c.json", emulate=True, clock=VirtualClock(), env_kwargs={"timing": Timing(time_scale=2)})
    with pytest.raises(TypeError, match=r"env_kwargs\['poses'\] must be a Poses record"):
        deploy(tmp_path / "c.json", emulate=True, env_kwargs={"poses": {"placement": "none"}})
