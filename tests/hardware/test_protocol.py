"""The codec against K-Team's documented formats (Khepera III manual, kh3server.c) and strict parsing."""
from __future__ import annotations

import pytest

from mahn_envs.hardware import protocol as P
from mahn_envs.hardware.errors import ProtocolError
from mahn_envs.hardware.kinematics import SPEED_UNIT_V3, Drive, Motion

N_LINE = "n,31,210,1120,3910,4000,640,58,22,17,911,905,1234567"


def test_commands_encode_as_documented():
    assert P.version().encode() == b"B\n"
    assert P.init_motors().encode() == b"M\n"
    assert P.read_proximity().encode() == b"N\n"
    assert P.read_speed().encode() == b"E\n"
    assert P.set_speed(15049, -15049).encode() == b"D,l15049,l-15049\n"
    assert P.set_speed(0, 0).encode("\r\n") == b"D,l0,l0\r\n"
    assert P.STOP.text == "D,l0,l0"


@pytest.mark.parametrize("bad", [1.5, True, 2**31, -(2**31) - 1, "10"])
def test_set_speed_rejects_non_int32(bad):
    with pytest.raises(ValueError, match="D: left"):
        P.set_speed(bad, 0)


def test_original_deployment_commands_are_reproduced():
    """The original sent D,l15049,l15049 forward and D,l15049,l-15049 to turn right (docs/original-system.md
    section 10)."""
    v = 15049 / SPEED_UNIT_V3 / 10.0  # cm/s of 15049 firmware units
    drive = Drive(forward_speed=v, turn_rate=2 * v / 8.85, wheel_base=8.85)
    assert drive.units(Motion.FORWARD, SPEED_UNIT_V3) == (15049, 15049)
    assert drive.units(Motion.RIGHT, SPEED_UNIT_V3) == (15049, -15049)
    assert drive.units(Motion.LEFT, SPEED_UNIT_V3) == (-15049, 15049)
    assert drive.units(Motion.STOP, SPEED_UNIT_V3) == (0, 0)


@pytest.mark.parametrize("eol", ["\r\n", "\n"])
@pytest.mark.parametrize("as_bytes", [True, False])
def test_documented_replies_parse(eol, as_bytes):
    def line(s):
        return (s + eol).encode() if as_bytes else s + eol

    assert P.parse_reply(line("b,3,0"), "B") == P.Version(3, 0)
    assert P.parse_reply(line("m"), "M") == P.Ack("m")
    assert P.parse_reply(line("d"), P.set_speed(1, 2)) == P.Ack("d")
    assert P.parse_reply(line("e,-120,4000"), "E") == P.Speeds(-120, 4000)
    n = P.parse_reply(line(N_LINE), "N")
    assert n.values == (31, 210, 1120, 3910, 4000, 640, 58, 22, 17, 911, 905)
    assert n.timestamp == 1234567
    assert n.front == (210, 1120, 3910, 4000, 640, 58)  # ring sensors 1..6, left to right
    o = P.parse_reply(line("o" + N_LINE[1:]), "O")
    assert o.values[0] == 31
    assert P.parse_reply(line("z"), "Z") == P.Ack("z")


@pytest.mark.parametrize("command,reply,why", [
    ("D,l0,l0", "e,1,2", "starting with 'd'"),
    ("D,l0,l0", "d,1", "bare acknowledgement"),
    ("N", "$", "rejected"),
    ("N", "n,1,2,3,4,5,6,7,8,9,10,99", "11 values"),
    ("N", "n,1,2,3,4,5,6,7,8,9,10,11,12,13", "11 values"),
    ("N", "n,1,2,3,x,5,6,7,8,9,10,11,99", "not a non-negative integer"),
    ("N", "n,1,2,3,-4,5,6,7,8,9,10,11,99", "not a non-negative integer"),
    ("N", "n,1,2,3,70000,5,6,7,8,9,10,11,99", "16 bits"),
    ("N", "n, 1,2,3,4,5,6,7,8,9,10,11,99", "not a non-negative integer"),
    ("B", "b,3", "2 fields"),
    ("B", "b,3,-1", "non-negative"),
    ("E", "e,1,2.5", "not an integer"),
    ("E", "", "starting with 'e'"),
    ("M", "m\x07", "control characters"),
])
def test_malformed_replies_are_errors_naming_robot_command_and_reply(command, reply, why):
    with pytest.raises(ProtocolError, match=why) as info:
        P.parse_reply(reply + "\r\n", command, robot="robot_2")
    err = info.value
    assert err.robot == "robot_2" and err.command == command and err.reply == reply
    assert "robot_2" in str(err) and repr(command) in str(err) and repr(reply) in str(err)
    assert isinstance(err, ValueError)


def test_non_ascii_reply_is_an_error():
    with pytest.raises(ProtocolError, match="not ASCII"):
        P.parse_reply(b"n,\xff\xfe\r\n", "N", "robot_0")


def test_unknown_command_has_no_reply_format():
    with pytest.raises(ValueError, match="no reply format"):
        P.parse_reply("x", "Q")


def test_robot_side_parsing_and_formatting_round_trip():
    cmd = P.parse_command(b"D,l-19685,l20260\r\n")
    assert P.speeds_of(cmd) == (-19685, 20260)
    assert P.parse_command("N").letter == "N"
    for bad in ["D,19685,19685", "D,l1", "D,l1,l2,l3", "N,1", "", "d", "NX", "D,l99999999999,l0"]:
        with pytest.raises(ValueError):
            P.parse_command(bad)
    vals = list(range(100, 111))
    rep = P.parse_reply(P.format_sensors("n", vals, 42), "N")
    assert rep.values == tuple(vals) and rep.timestamp == 42
    assert P.parse_reply(P.format_version(3, 1), "B") == P.Version(3, 1)
    assert P.parse_reply(P.format_speeds(-5, 5), "E") == P.Speeds(-5, 5)
    assert P.format_error() == b"$\r\n"
