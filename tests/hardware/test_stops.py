"""Stops on the fault paths: a reply counts for a command only when it answers one of that command's own writes
(so a stop is confirmed only when the robot really got a stop), unconfirmed stops are resent in the background,
and all robots are stopped in parallel."""
from __future__ import annotations

import threading
import time
import warnings

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from mahn_envs.hardware import Link, Poses, RetryPolicy
from mahn_envs.hardware import protocol as P
from mahn_envs.hardware.clock import RealClock
from mahn_envs.hardware.errors import ProtocolError, RobotTimeout
from mahn_envs.hardware.transport import RobotLink

from .conftest import last_command
from .test_transport import make_link

pytestmark = pytest.mark.timeout(60)


def _drive(env, n=3):
    for _ in range(n):
        env.step({a: 1 for a in env.agents})


# ---------------------------------------------------------------------------------------------- the false ack
def test_a_late_drive_reply_is_not_taken_for_the_stop_acknowledgement(make_env):
    # robot_1 answers its next two D commands 2 s late each (the emulator's handler is blocked, so the line
    # stays FIFO): the drive command times out (3 attempts of 0.6 s), the emergency stop then sees the late `d`
    # of the abandoned drive command at 2 s - which must not count as the stop's reply: the robot is driving
    env, emu = make_env(link=Link(retry=RetryPolicy(timeout=0.6, attempts=3)))
    env.reset()
    _drive(env)
    emu.inject(1, "delay", count=2, letters="D", delay=2.0)
    with pytest.raises(RobotTimeout, match="robot_1"), warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        _drive(env)
    report = dict(env.last_stop_report)
    moving = not emu.world.stopped(1)
    assert report["robot_0"] is None and report["robot_2"] is None
    assert moving and report["robot_1"] is not None, report  # honest: it is still driving
    assert report["robot_1"].startswith("unconfirmed")
    assert any("not confirmed" in str(w.message) and "robot_1" in str(w.message) for w in caught)
    assert env._links[1].stats.stale_replies >= 1  # the late `d` was seen and dropped
    assert env.unconfirmed_stops == ["robot_1"]
    with pytest.raises(RuntimeError, match=r"stop of \['robot_1'\] is not confirmed"):
        env.reset()  # no driving while a stop is unconfirmed
    # the stop is resent in the background; once the robot answers one of those stops, the report updates
    assert env.wait_stops(timeout=20.0) == []
    assert env.last_stop_report["robot_1"] is None
    assert emu.world.stopped(1) and last_command(emu, 1) == "D,l0,l0"
    assert env.give_up_stops() == []  # nothing to give up; a confirmed robot's link stays open
    env.reset()  # the link is the env's again
    _drive(env, 2)
    assert not emu.world.stopped(1)


def test_a_stale_reply_of_the_same_letter_never_confirms_a_stop():
    link, (port,) = make_link([None, None, None])
    with pytest.raises(RobotTimeout):
        link.transact(P.set_speed(500, 500))  # three writes, no reply yet
    port.script = [b"d\r\n"]  # the late reply to the first drive write arrives while the stop waits
    with pytest.raises(RobotTimeout):
        link.transact(P.STOP, RetryPolicy(timeout=0.05, attempts=1))
    assert link.stats.stale_replies == 1 and link.unanswered_writes == 3  # 2 drive writes + the stop
    # a new stop, resent: the robot answers in order - two drive writes, the first stop, then the new stop
    port.script = [b"d\r\nd\r\n", None, b"d\r\nd\r\n"]
    replies = []
    link.cancel()
    reply = link.transact_until_answered(P.STOP, 0.05, threading.Event(), on_error=replies.append)
    assert reply == P.Ack("d") and link.stats.stale_replies == 4 and link.unanswered_writes == 2
    assert [type(e) for e in replies] == [RobotTimeout, RobotTimeout]


def test_lost_commands_are_popped_and_the_error_mark_goes_to_the_oldest_write():
    n_reply = b"n,1,2,3,4,5,6,7,8,9,10,11,12\r\n"
    link, (port,) = make_link([None, None, None, b"$\r\n" + n_reply])
    with pytest.raises(RobotTimeout):
        link.transact(P.read_speed())  # E: lost
    # N: its answer `n` pops the lost E writes; `$` in front of it answers the oldest write (an E): stale
    assert link.transact(P.read_proximity(), RetryPolicy(timeout=0.05, attempts=1)).timestamp == 12
    assert link.stats.stale_replies == 1 and link.unanswered_writes == 0
    link2, _ = make_link([b"d\r\n"])  # a reply to nothing written on this line is an error, never an answer
    with pytest.raises(ProtocolError, match="starting with 'n'"):
        link2.transact(P.read_proximity())


class FifoRobot:
    """A pyserial-like port of a robot that answers in order: the reply to each write carries the write's index,
    each write is either answered or lost (`fates`), and a reply shows up only `lag` writes later (in order)."""

    def __init__(self, fates, timeout):
        self.fates = fates
        self.timeout = timeout
        self.written: list[str] = []
        self.outbox: list[tuple[int, bytes]] = []  # (release at write count, reply)
        self.inbox = bytearray()

    def write(self, data):
        i = len(self.written)
        text = data.decode().strip()
        self.written.append(text)
        answered, lag = self.fates[i % len(self.fates)]
        if answered:
            release = max([i + lag] + [r for r, _ in self.outbox])
            reply = f"e,{i},0\r\n" if text == "E" else "n" + ",0" * 11 + f",{i}\r\n"
            self.outbox.append((release, reply.encode()))
        while self.outbox and self.outbox[0][0] <= i:
            self.inbox.extend(self.outbox.pop(0)[1])
        return len(data)

    def flush(self):
        pass

    @property
    def in_waiting(self):
        return len(self.inbox)

    def read(self, n):
        if not self.inbox:
            time.sleep(self.timeout / 10)
            return b""
        out = bytes(self.inbox[:n])
        del self.inbox[:n]
        return out

    def reset_input_buffer(self):
        self.inbox.clear()

    def close(self):
        pass


@settings(max_examples=40, deadline=None)
@given(fates=st.lists(st.tuples(st.booleans(), st.integers(0, 4)), min_size=1, max_size=8),
       letters=st.lists(st.sampled_from("EN"), min_size=1, max_size=12))
def test_every_accepted_reply_answers_one_of_its_own_commands_writes(fates, letters):
    port = FifoRobot(fates, 0.002)
    link = RobotLink("fifo://", "robot_0", RetryPolicy(timeout=0.002, attempts=3), opener=lambda *a: port).open()
    for letter in letters:
        first = len(port.written)
        try:
            reply = link.transact(P.Command(letter))
        except RobotTimeout:
            continue
        index = reply.left if letter == "E" else reply.timestamp
        assert first <= index < len(port.written), (letter, index, first, port.written)
        assert port.written[index] == letter


# ---------------------------------------------------------------------------------------------- parallel stops
def test_stops_go_to_every_robot_in_parallel(make_env):
    # a frozen bridge: no robot answers; every robot must get its first stop before any robot's stop is resent
    env, emu = make_env(emu_kwargs={"clock": RealClock()}, link=Link(retry=RetryPolicy(timeout=0.25, attempts=2)))
    env.reset()
    _drive(env, 2)
    for k in range(3):
        emu.inject(k, "drop", count=None)
    t0 = time.monotonic()
    with pytest.raises(RobotTimeout), warnings.catch_warnings():
        warnings.simplefilter("ignore")
        _drive(env)
    assert time.monotonic() - t0 < 5.0  # generous: 2 x 0.25 s to detect, 2 x 0.25 s for the stops
    time.sleep(0.3)  # let every robot see a resent stop
    stops = [[t for t, c in emu.command_log(k) if c == "D,l0,l0"][-2:] for k in range(3)]
    assert all(len(s) == 2 for s in stops), stops
    assert max(s[0] for s in stops) < min(s[1] for s in stops), stops
    assert sorted(env.unconfirmed_stops) == ["robot_0", "robot_1", "robot_2"]
    assert env.give_up_stops() == ["robot_0", "robot_1", "robot_2"] and env.unconfirmed_stops == []


def test_deploy_waits_until_an_unconfirmed_stop_is_confirmed(tmp_path, capsys, make_emulator, vclock):
    # the background resending ends with the program: deploy must not return while a robot may still drive
    import json

    from mahn_evo.deploy import deploy

    from ..envs.helpers import random_team

    champ = tmp_path / "champion.json"
    champ.write_text(json.dumps({"controllers": random_team(3).to_dict()}))
    emu = make_emulator(clock=vclock)
    ticks = []

    def on_tick(tick, infos):
        ticks.append(tick)
        if tick == 3:
            emu.inject(1, "delay", count=2, letters="D", delay=1.0)

    with pytest.raises(RobotTimeout, match="robot_1"), warnings.catch_warnings():
        warnings.simplefilter("ignore")
        deploy(champ, emu.ports, clock=vclock, on_tick=on_tick, log_path=tmp_path / "log.csv",
               env_kwargs={"poses": Poses(placement="none"), "link": Link(retry=RetryPolicy(timeout=0.2, attempts=2)),
                           "catch_sigterm": False})
    assert emu.world.stopped(1) and last_command(emu, 1) == "D,l0,l0"  # deploy waited for the real stop
    err = capsys.readouterr().err
    assert "stop of ['robot_1'] is not confirmed" in err and "stop of ['robot_1'] confirmed" in err
