"""Fault injection through the emulator: no reply, garbage, delay, disconnect - and the stops that follow."""
from __future__ import annotations

import time
import warnings

import pytest

from mahn_envs.hardware import Link, Poses, RetryPolicy, Timing
from mahn_envs.hardware.emulator import parse_fault
from mahn_envs.hardware.errors import LinkError, ProtocolError, RobotTimeout

from .conftest import last_command

pytestmark = pytest.mark.timeout(60)

FAST = RetryPolicy(timeout=0.25, attempts=3, reconnects=1)


def _drive(env, n=3):
    for _ in range(n):
        env.step({a: 1 for a in env.agents})


def _all_stopped(emu, robots=(0, 1, 2)):
    return all(last_command(emu, k) == "D,l0,l0" and emu.world.stopped(k) for k in robots)


def test_one_dropped_reply_is_retried_transparently(make_env):
    env, emu = make_env(link=Link(retry=FAST))
    env.reset()
    emu.inject(1, "drop", count=1, letters="N")
    _drive(env)
    assert env._links[1].stats.retries == 1
    assert not emu.world.stopped(1)  # still running normally


def test_a_robot_that_stops_answering_stops_the_team(make_env):
    env, emu = make_env(link=Link(retry=FAST))
    env.reset()
    _drive(env)
    emu.inject(1, "drop", count=None)  # robot_1 goes silent for good
    t0 = time.monotonic()
    with pytest.raises(RobotTimeout) as info, pytest.warns(UserWarning, match="stop not confirmed.*robot_1"):
        _drive(env)
    assert time.monotonic() - t0 < 5.0  # bounded: attempts x timeout, plus the stop attempts
    assert info.value.robot == "robot_1"
    assert _all_stopped(emu, (0, 2))  # the robots that answer were stopped ...
    assert env.last_stop_report["robot_0"] is None and env.last_stop_report["robot_2"] is None
    assert env.last_stop_report["robot_1"].startswith("unconfirmed: RobotTimeout")  # ... the silent one was tried
    assert env.unconfirmed_stops == ["robot_1"]  # and is still being tried
    assert emu.commands(1)[-1] == "D,l0,l0"
    assert env.agents == []


def test_garbage_is_an_error_naming_robot_command_and_reply_and_stops_the_team(make_env):
    env, emu = make_env(link=Link(retry=FAST))
    env.reset()
    _drive(env)
    emu.inject(2, "garbage", count=1, letters="N")
    with pytest.raises(ProtocolError) as info:
        _drive(env)
    err = info.value
    assert err.robot == "robot_2" and err.command == "N" and "garbage" in err.reply
    assert "robot_2" in str(err) and "'N'" in str(err)
    assert _all_stopped(emu)


def test_garbage_in_reply_to_a_speed_command(make_env):
    env, emu = make_env(link=Link(retry=FAST))
    env.reset()
    emu.inject(0, "garbage", count=1, letters="D")
    with pytest.raises(ProtocolError, match="robot_0.*'D,l19685,l19685'"):
        _drive(env)
    assert _all_stopped(emu)


def test_delay_within_the_timeout_is_fine_beyond_it_is_retried(make_env):
    env, emu = make_env(link=Link(retry=FAST))
    env.reset()
    emu.inject(0, "delay", count=1, letters="N", delay=0.1)
    _drive(env)
    assert env._links[0].stats.retries == 0
    emu.inject(0, "delay", count=1, letters="N", delay=0.4)  # longer than the 0.25 s timeout
    _drive(env, 5)
    link = env._links[0]
    assert link.stats.retries == 1 and link.stats.stale_replies == 1  # the late duplicate was recognised
    assert not emu.world.stopped(0)


def test_a_reply_later_than_every_attempt_times_out_and_stops(make_env):
    env, emu = make_env(link=Link(retry=RetryPolicy(timeout=0.2, attempts=2)))
    env.reset()
    emu.inject(2, "delay", count=1, letters="N", delay=1.0)
    with pytest.raises(RobotTimeout, match="robot_2.*'N'"), warnings.catch_warnings():
        warnings.simplefilter("ignore")  # robot_2's own stop may or may not be answered in time
        _drive(env)
    assert _all_stopped(emu, (0, 1))
    # robot_2's stop was sent too; its server is busy with the delayed reply and executes it afterwards
    deadline = time.monotonic() + 5.0
    while not _all_stopped(emu, (2,)) and time.monotonic() < deadline:
        time.sleep(0.02)
    assert _all_stopped(emu, (2,))


def test_one_disconnect_is_survived_by_reconnecting(make_env):
    env, emu = make_env(link=Link(retry=FAST))
    env.reset()
    emu.inject(1, "disconnect", count=1, letters="D")
    _drive(env)
    assert env._links[1].stats.reconnects == 1 and emu.connections[1] == 2
    assert not emu.world.stopped(1)


def test_a_lost_link_stops_the_others(make_env):
    env, emu = make_env(link=Link(retry=FAST))
    env.reset()
    _drive(env)
    emu.inject(0, "disconnect", count=None)
    with pytest.raises(LinkError) as info, pytest.warns(UserWarning, match="stop not confirmed.*robot_0"):
        _drive(env)
    assert info.value.robot == "robot_0"
    assert _all_stopped(emu, (1, 2))
    assert env.last_stop_report["robot_0"] is not None
    # a real robot keeps its last speeds when its link dies: only a robot-side watchdog helps
    assert not emu.world.stopped(0)


def test_robot_side_watchdog_stops_an_unreachable_robot(make_emulator, vclock):
    emu = make_emulator(clock=vclock, watchdog=0.5)
    from mahn_envs.hardware import KheperaHardwareEnv

    env = KheperaHardwareEnv(emu.ports, timing=Timing(clock=vclock), poses=Poses(placement="none"),
                             catch_sigterm=False, link=Link(retry=FAST))
    try:
        env.reset()
        _drive(env)
        assert not emu.world.stopped(0)
        vclock.advance(0.6)  # no command for longer than the watchdog
        emu.world.advance()
        assert all(emu.world.stopped(k) for k in range(3))
    finally:
        env.close()


def test_fault_specs():
    f = parse_fault("1:drop:forever:N")
    assert (f.robot, f.kind, f.count, f.letters) == (1, "drop", None, "N")
    f = parse_fault("0:delay:2:ND:0.6")
    assert (f.count, f.letters, f.delay) == (2, "ND", 0.6)
    for bad in ["x:drop", "1:explode", "1", "1:drop:-1"]:
        with pytest.raises(ValueError):
            parse_fault(bad)
