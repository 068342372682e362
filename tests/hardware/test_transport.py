"""RobotLink: line framing, timeouts and bounded retries, late replies, reconnects (on a scripted fake port)."""
from __future__ import annotations

import time

import pytest
import serial

from mahn_envs.hardware import protocol as P
from mahn_envs.hardware.errors import LinkError, ProtocolError, RobotTimeout
from mahn_envs.hardware.transport import RetryPolicy, RobotLink

N_REPLY = b"n,1,2,3,4,5,6,7,8,9,10,11,12\r\n"


class FakePort:
    """A pyserial-like port whose replies come from `script`: a list of what to answer each write
    (bytes, None for silence, or an exception to raise on write)."""

    def __init__(self, script, timeout):
        self.script = list(script)
        self.timeout = timeout
        self.inbox = bytearray()
        self.written: list[bytes] = []
        self.closed = False
        self.broken = False

    def write(self, data):
        self.written.append(bytes(data))
        answer = self.script.pop(0) if self.script else None
        if isinstance(answer, Exception):
            raise answer
        if answer:
            self.inbox.extend(answer)
        return len(data)

    def flush(self):
        pass

    @property
    def in_waiting(self):
        return len(self.inbox)

    def read(self, n):
        if self.broken:
            raise serial.SerialException("socket disconnected")
        if not self.inbox:
            time.sleep(self.timeout)
            return b""
        out = bytes(self.inbox[:n])
        del self.inbox[:n]
        return out

    def reset_input_buffer(self):
        self.inbox.clear()

    def close(self):
        self.closed = True


def make_link(*scripts, policy=None, eol="\n"):
    ports = []

    def opener(url, timeout, baudrate):
        if not scripts[len(ports):]:
            raise serial.SerialException("could not open port")
        port = FakePort(scripts[len(ports)], timeout)
        ports.append(port)
        return port

    link = RobotLink("fake://robot", "robot_1", policy or RetryPolicy(timeout=0.05, attempts=3), eol=eol,
                     opener=opener)
    return link.open(), ports


def test_reply_split_across_reads_and_either_line_end():
    link, (port,) = make_link([b"d\n", b"e,5,-5\r\n"])
    assert link.transact(P.set_speed(1, 2)) == P.Ack("d")
    assert port.written == [b"D,l1,l2\n"]
    assert link.transact(P.read_speed()) == P.Speeds(5, -5)

    link, (port,) = make_link([b""])
    port.inbox.extend(b"n,1,2,3,4,5,6,")  # half a line now, the rest below
    port.script = [b"7,8,9,10,11,12\r\n"]
    assert link.transact(P.read_proximity()).values == tuple(range(1, 12))


def test_command_line_end_is_configurable():
    link, (port,) = make_link([b"m\r\n"], eol="\r\n")
    link.transact(P.init_motors())
    assert port.written == [b"M\r\n"]


def test_timeout_is_retried_then_reported_with_robot_and_command():
    link, (port,) = make_link([None, N_REPLY])
    assert link.transact(P.read_proximity()).timestamp == 12
    assert link.stats.retries == 1 and len(port.written) == 2

    link, (port,) = make_link([None, None, None, N_REPLY])
    t0 = time.monotonic()
    with pytest.raises(RobotTimeout) as info:
        link.transact(P.read_proximity())
    assert time.monotonic() - t0 < 1.0  # bounded: 3 attempts of 0.05 s (plus one read slice each)
    assert info.value.robot == "robot_1" and info.value.command == "N"
    assert "3 attempt" in str(info.value) and len(port.written) == 3


def test_garbage_is_not_retried():
    link, (port,) = make_link([b"?%garbage\r\n", N_REPLY])
    with pytest.raises(ProtocolError) as info:
        link.transact(P.read_proximity())
    assert info.value.reply == "?%garbage" and len(port.written) == 1


def test_late_reply_of_an_abandoned_command_is_discarded():
    # N times out once; the retry gets both replies; the extra one shows up before D's reply and is dropped
    link, (port,) = make_link([None, N_REPLY + N_REPLY, b"d\r\n"])
    assert link.transact(P.read_proximity()).values[0] == 1
    assert link.transact(P.STOP) == P.Ack("d")
    assert link.stats.stale_replies == 1
    # without an abandoned N, an n line in front of a d reply is an error
    link, _ = make_link([N_REPLY])
    with pytest.raises(ProtocolError, match="starting with 'd'"):
        link.transact(P.STOP)


def test_dropped_link_is_reopened_once_then_reported():
    link, ports = make_link([None], [b"d\r\n"])
    ports[0].broken = True
    assert link.transact(P.STOP) == P.Ack("d")
    assert link.stats.reconnects == 1 and ports[0].closed

    link, ports = make_link([None], [None])
    ports[0].broken = True

    def break_next(url, timeout, baudrate):  # the reopened port is dead too
        raise serial.SerialException("connection refused")

    link.opener = break_next
    with pytest.raises(LinkError, match="robot_1.*could not be reopened"):
        link.transact(P.STOP)


def test_cancel_and_pending_bookkeeping():
    link, (port,) = make_link([None, b"d\r\n"])
    link.send(P.read_proximity())
    with pytest.raises(RuntimeError, match="still waits"):
        link.send(P.STOP)
    link.cancel()  # e.g. after another robot failed: its N reply, if it comes, will be discarded
    port.inbox.extend(N_REPLY)
    assert link.transact(P.STOP) == P.Ack("d")
    assert link.stats.stale_replies == 1


def test_open_failure_names_robot_and_url():
    link = RobotLink("socket://127.0.0.1:1", "robot_0", RetryPolicy(timeout=0.2))
    with pytest.raises(LinkError, match="robot_0.*cannot open 'socket://127.0.0.1:1'"):
        link.open()


def test_retry_policy_validation():
    for bad in [dict(timeout=0), dict(attempts=0), dict(reconnects=-1), dict(backoff=-1)]:
        with pytest.raises(ValueError):
            RetryPolicy(**bad)


def test_the_write_timeout_is_not_the_read_polling_step():
    """A 10 ms write timeout (the read polling step) made healthy links fail and reconnect on a busy machine."""
    from mahn_envs.hardware.transport import WRITE_TIMEOUT, open_url

    port = open_url("loop://", 0.01, 115200)
    try:
        assert port.timeout == 0.01 and port.write_timeout == WRITE_TIMEOUT >= 0.5
    finally:
        port.close()
