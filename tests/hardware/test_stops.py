"""Stops on the fault paths: a stop counts only when its own reply arrives, unconfirmed stops are retried in the
background, and all robots are stopped in parallel."""
from __future__ import annotations

import time
import warnings

import pytest

from mahn_envs.hardware import RetryPolicy
from mahn_envs.hardware.errors import RobotTimeout

from .conftest import last_command

pytestmark = pytest.mark.timeout(60)


def _drive(env, n=3):
    for _ in range(n):
        env.step({a: 1 for a in env.agents})


def _received_stop(emu, k):
    return "D,l0,l0" in emu.commands(k)


def test_a_late_drive_reply_is_not_taken_for_the_stop_acknowledgement(make_env):
    # robot_1 answers its next three D commands 2 s late each (the handler is blocked, so the line stays
    # FIFO): the drive command times out (3 attempts of 0.6 s); the emergency stop then sees the late `d` of
    # the abandoned drive command, which must not count as the stop's reply - the robot is still driving
    env, emu = make_env(retry=RetryPolicy(timeout=0.6, attempts=3))
    env.reset()
    _drive(env)
    emu.inject(1, "delay", count=3, letters="D", delay=2.0)
    with pytest.raises(RobotTimeout, match="robot_1"), warnings.catch_warnings():
        warnings.simplefilter("ignore")
        _drive(env)
    report = dict(env.last_stop_report)
    assert report["robot_0"] is None and report["robot_2"] is None
    if report["robot_1"] is None:  # reported stopped: then the robot really got and executed a stop
        assert _received_stop(emu, 1) and last_command(emu, 1) == "D,l0,l0" and emu.world.stopped(1)
    print(report, emu.commands(1)[-8:], emu.world.stopped(1), env._links[1].stats)
