"""Codec for the Khepera III ASCII command protocol (K-Team's serial protocol, as served by ``kh3server``).

One command per line, comma-separated, starting with an upper-case letter; the robot answers one line that
starts with the same letter in lower case, or ``$`` when it rejects the command.  Formats (K-Team manual and
``kh3server.c``; replies end in ``\\r\\n``)::

    B                  -> b,<version>,<revision>
    M                  -> m                       (re)initialise the motor controllers
    D,l<left>,l<right> -> d                       wheel speed set points, signed 32-bit, "l" = long
    E                  -> e,<left>,<right>        measured wheel speeds
    N                  -> n,<v0>,...,<v10>,<timestamp>   the 11 proximity values (9 ring + 2 floor)
    O                  -> o,<v0>,...,<v10>,<timestamp>   the 11 ambient values
    Z                  -> z                       reset the timestamp
    anything unknown   -> $

Both directions live here: the hardware env encodes commands and parses replies, the emulator parses commands
and formats replies, so the two cannot drift apart.  Parsing is strict: a reply that is not exactly the
documented shape is a :class:`ProtocolError` naming the robot, the command and the reply.  Line ends ``\\n`` and
``\\r\\n`` are both accepted (the firmware sends ``\\r\\n``, serial bridges and the original .NET code use
``\\n``).
"""
from __future__ import annotations

import re
from dataclasses import dataclass

from .errors import ProtocolError

#: Reply letter expected for each command letter.
REPLY_LETTER = {"B": "b", "D": "d", "E": "e", "M": "m", "N": "n", "O": "o", "Z": "z"}
ERROR_MARK = "$"
N_PROXIMITY = 11  # 9 ring sensors + 2 floor sensors
INT32_MIN, INT32_MAX = -(2**31), 2**31 - 1
#: The six front ring sensors the task uses, left to right (firmware indices of the N reply).
FRONT_SENSORS = (1, 2, 3, 4, 5, 6)

_INT = re.compile(r"-?[0-9]+\Z")
_UINT = re.compile(r"[0-9]+\Z")


@dataclass(frozen=True)
class Command:
    """One command line: a letter and its comma-separated arguments (already formatted)."""

    letter: str
    args: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        if len(self.letter) != 1 or not ("A" <= self.letter <= "Z"):
            raise ValueError(f"a command letter is one upper-case letter, got {self.letter!r}")

    @property
    def text(self) -> str:
        return ",".join((self.letter,) + self.args)

    def encode(self, eol: str = "\n") -> bytes:
        return (self.text + eol).encode("ascii")

    def __str__(self) -> str:
        return self.text


# ---------------------------------------------------------------------------------------------- commands
def version() -> Command:
    return Command("B")


def init_motors() -> Command:
    return Command("M")


def set_speed(left: int, right: int) -> Command:
    """``D,l<left>,l<right>``: the firmware strips the first character of each argument (the ``l``), so it
    must always be present."""
    for name, v in (("left", left), ("right", right)):
        if isinstance(v, bool) or not isinstance(v, int):
            raise ValueError(f"D: {name} wheel speed must be an int (firmware units), got {v!r}")
        if not INT32_MIN <= v <= INT32_MAX:
            raise ValueError(f"D: {name} wheel speed {v} does not fit a signed 32-bit value")
    return Command("D", (f"l{left}", f"l{right}"))


STOP = set_speed(0, 0)


def read_speed() -> Command:
    return Command("E")


def read_proximity() -> Command:
    return Command("N")


def reset_timestamp() -> Command:
    return Command("Z")


# ---------------------------------------------------------------------------------------------- replies
@dataclass(frozen=True)
class Ack:
    """A bare acknowledgement (``d``, ``m``, ``z``)."""

    letter: str


@dataclass(frozen=True)
class Version:
    version: int
    revision: int


@dataclass(frozen=True)
class Speeds:
    left: int
    right: int


@dataclass(frozen=True)
class SensorReading:
    """The 11 values of an ``N`` (proximity) or ``O`` (ambient) reply and the robot's timestamp."""

    values: tuple[int, ...]
    timestamp: int

    @property
    def front(self) -> tuple[int, ...]:
        """The six front sensors, left to right: the task's sensor order."""
        return tuple(self.values[i] for i in FRONT_SENSORS)


Reply = Ack | Version | Speeds | SensorReading


def _line_text(line: bytes | str, robot: str, command: str) -> str:
    """Strip exactly one line end (``\\n`` or ``\\r\\n``) and check the rest is printable ASCII."""
    if isinstance(line, bytes):
        try:
            text = line.decode("ascii")
        except UnicodeDecodeError:
            raise ProtocolError(robot, command, "reply is not ASCII", reply=repr(line)[2:-1]) from None
    else:
        text = line
    if text.endswith("\r\n"):
        text = text[:-2]
    elif text.endswith("\n"):
        text = text[:-1]
    if any(not (32 <= ord(c) < 127) for c in text):
        raise ProtocolError(robot, command, "reply contains control characters", reply=text)
    return text


def _ints(fields: list[str], robot: str, command: str, reply: str, unsigned: bool = False) -> list[int]:
    pattern = _UINT if unsigned else _INT
    out = []
    for i, f in enumerate(fields):
        if not pattern.match(f):
            kind = "a non-negative integer" if unsigned else "an integer"
            raise ProtocolError(robot, command, f"field {i + 1} ({f!r}) is not {kind}", reply=reply)
        out.append(int(f))
    return out


def parse_reply(line: bytes | str, command: Command | str, robot: str = "?") -> Reply:
    """Parse the reply to `command` strictly; raise :class:`ProtocolError` for anything else."""
    cmd = command.text if isinstance(command, Command) else str(command)
    letter = cmd[:1]
    if letter not in REPLY_LETTER:
        raise ValueError(f"no reply format known for command {cmd!r} (known: {sorted(REPLY_LETTER)})")
    text = _line_text(line, robot, cmd)
    if text == ERROR_MARK:
        raise ProtocolError(robot, cmd, "the robot rejected the command ($: unknown command or bad arguments)",
                            reply=text)
    fields = text.split(",")
    expected = REPLY_LETTER[letter]
    if fields[0] != expected:
        raise ProtocolError(robot, cmd, f"expected a reply starting with {expected!r}", reply=text)
    rest = fields[1:]
    if expected in ("d", "m", "z"):
        if rest:
            raise ProtocolError(robot, cmd, f"expected the bare acknowledgement {expected!r}", reply=text)
        return Ack(expected)
    if expected in ("b", "e"):
        if len(rest) != 2:
            raise ProtocolError(robot, cmd, f"expected 2 fields after {expected!r}, got {len(rest)}", reply=text)
        a, b = _ints(rest, robot, cmd, text, unsigned=(expected == "b"))
        return Version(a, b) if expected == "b" else Speeds(a, b)
    # n / o: 11 sensor values and a timestamp
    if len(rest) != N_PROXIMITY + 1:
        raise ProtocolError(robot, cmd, f"expected {N_PROXIMITY} values and a timestamp after {expected!r}, "
                            f"got {len(rest)} fields", reply=text)
    nums = _ints(rest, robot, cmd, text, unsigned=True)
    if any(v > 0xFFFF for v in nums[:-1]):
        raise ProtocolError(robot, cmd, "a sensor value exceeds 16 bits", reply=text)
    return SensorReading(tuple(nums[:-1]), nums[-1])


# ---------------------------------------------------------------------------------------------- robot side
def parse_command(line: bytes | str) -> Command:
    """Parse a command line as the robot does (used by the emulator).  Raises ValueError when the robot would
    answer ``$``.  Stricter than ``kh3server``: ``D`` needs exactly two ``l``-prefixed 32-bit integers."""
    text = line.decode("ascii") if isinstance(line, bytes) else line
    text = text.rstrip("\r\n")
    if not text or not ("A" <= text[0] <= "Z"):
        raise ValueError(f"not a command: {text!r}")
    if len(text) > 1 and text[1] != ",":
        raise ValueError(f"command letter must be followed by ',' or the line end: {text!r}")
    letter = text[0]
    args = tuple(text[2:].split(",")) if len(text) > 2 else ()
    if letter == "D":
        if len(args) != 2 or any(not (a.startswith("l") and _INT.match(a[1:])) for a in args):
            raise ValueError(f"D needs two l-prefixed integers, got {text!r}")
        vals = [int(a[1:]) for a in args]
        if any(not INT32_MIN <= v <= INT32_MAX for v in vals):
            raise ValueError(f"D speed out of 32-bit range: {text!r}")
    elif letter in REPLY_LETTER and args:
        raise ValueError(f"{letter} takes no arguments: {text!r}")
    return Command(letter, args)


def speeds_of(command: Command) -> tuple[int, int]:
    """The (left, right) set points of a parsed ``D`` command."""
    if command.letter != "D":
        raise ValueError(f"not a D command: {command.text!r}")
    return int(command.args[0][1:]), int(command.args[1][1:])


def format_ack(letter: str, eol: str = "\r\n") -> bytes:
    return f"{letter}{eol}".encode("ascii")


def format_version(version_: int, revision: int, eol: str = "\r\n") -> bytes:
    return f"b,{int(version_)},{int(revision)}{eol}".encode("ascii")


def format_speeds(left: int, right: int, eol: str = "\r\n") -> bytes:
    return f"e,{int(left)},{int(right)}{eol}".encode("ascii")


def format_sensors(letter: str, values, timestamp: int, eol: str = "\r\n") -> bytes:
    vals = [int(v) for v in values]
    if len(vals) != N_PROXIMITY:
        raise ValueError(f"{letter} reply needs {N_PROXIMITY} values, got {len(vals)}")
    return (letter + "".join(f",{v}" for v in vals) + f",{int(timestamp)}{eol}").encode("ascii")


def format_error(eol: str = "\r\n") -> bytes:
    return f"{ERROR_MARK}{eol}".encode("ascii")
