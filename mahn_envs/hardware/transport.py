"""One link per robot: a pyserial URL, line framing, read timeouts and a bounded retry policy.

Any URL pyserial opens works: ``/dev/ttyUSB0``, ``/dev/rfcomm0`` (Bluetooth), ``socket://host:port`` (a network
serial bridge such as ser2net, or the emulator), ``rfc2217://host:port``.  A link sends one command and reads
one reply line; :meth:`RobotLink.send` / :meth:`RobotLink.finish` split the two so the env can put a command on
every robot's line before waiting for the first reply (three robots cost one round trip, not three).

Failure handling, kept small and bounded:
- no reply within ``timeout`` -> the command is sent again, at most ``attempts`` times in all, then
  :class:`RobotTimeout`;
- the connection drops -> the port is reopened (at most ``reconnects`` times per command) and the command
  resent, then :class:`LinkError`;
- a malformed reply -> :class:`ProtocolError` at once (no retry: garbage means something is wrong with the
  line or the firmware, and guessing would hide it).
All commands this package sends are idempotent set-points or reads, so resending is safe.  A reply that arrives
after its attempt was abandoned is recognised by its letter and discarded when it shows up in front of a later
command's reply.
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Any, Callable, Optional

from . import protocol as P
from .errors import LinkError, ProtocolError, RobotTimeout

try:  # pyserial is the optional "hardware" dependency
    import serial as _serial
except ImportError:  # pragma: no cover - exercised only without pyserial
    _serial = None

MAX_LINE = 256  # the longest valid reply (N) is about 80 characters


@dataclass(frozen=True)
class RetryPolicy:
    """Timeout per attempt (seconds of wall time), attempts per command, reopenings of a dropped link."""

    timeout: float = 0.4  # the original deployment's read timeout
    attempts: int = 3
    reconnects: int = 1
    backoff: float = 0.0  # wall seconds between attempts

    def __post_init__(self) -> None:
        if not (self.timeout > 0):
            raise ValueError(f"RetryPolicy.timeout must be > 0 seconds, got {self.timeout!r}")
        if isinstance(self.attempts, bool) or not isinstance(self.attempts, int) or self.attempts < 1:
            raise ValueError(f"RetryPolicy.attempts must be an integer >= 1, got {self.attempts!r}")
        if isinstance(self.reconnects, bool) or not isinstance(self.reconnects, int) or self.reconnects < 0:
            raise ValueError(f"RetryPolicy.reconnects must be an integer >= 0, got {self.reconnects!r}")
        if not (self.backoff >= 0):
            raise ValueError(f"RetryPolicy.backoff must be >= 0, got {self.backoff!r}")


@dataclass
class LinkStats:
    commands: int = 0
    retries: int = 0
    reconnects: int = 0
    stale_replies: int = 0
    last_round_trip: float = 0.0


class _NoLine(Exception):
    """Internal: the deadline passed before a complete line arrived."""


def open_url(url: str, timeout: float, baudrate: int) -> Any:
    if _serial is None:
        raise ImportError("the hardware env needs pyserial: pip install 'mahn[hardware]'")
    return _serial.serial_for_url(url, baudrate=baudrate, timeout=timeout, write_timeout=timeout)


def _link_errors() -> tuple[type, ...]:
    errs: tuple[type, ...] = (OSError, EOFError)
    if _serial is not None:
        errs = errs + (_serial.SerialException,)
    return errs


@dataclass
class RobotLink:
    """The line to one robot.  Not thread-safe: one link is driven by one thread."""

    url: str
    name: str
    policy: RetryPolicy = field(default_factory=RetryPolicy)
    baudrate: int = 115200
    eol: str = "\n"
    opener: Callable[[str, float, int], Any] = open_url
    stats: LinkStats = field(default_factory=LinkStats)

    def __post_init__(self) -> None:
        if self.eol not in ("\n", "\r\n", "\r"):
            raise ValueError(f"eol must be '\\n', '\\r\\n' or '\\r', got {self.eol!r}")
        self._port: Any = None
        self._buf = bytearray()
        self._pending: Optional[P.Command] = None
        self._sent = False
        self._stale: dict[str, int] = {}

    # ------------------------------------------------------------------ open / close
    @property
    def is_open(self) -> bool:
        return self._port is not None

    def open(self) -> "RobotLink":
        if self._port is None:
            try:
                # a short per-read timeout: whole-line deadlines are enforced here, not by pyserial
                self._port = self.opener(self.url, min(self.policy.timeout, 0.05), self.baudrate)
            except _link_errors() as exc:
                raise LinkError(self.name, "(open)", f"cannot open {self.url!r}: {exc}") from exc
            self._buf.clear()
            self._stale.clear()
        return self

    def close(self) -> None:
        port, self._port = self._port, None
        self._pending = None
        if port is not None:
            try:
                port.close()
            except _link_errors():
                pass

    def reopen(self) -> None:
        self.close()
        self.stats.reconnects += 1
        self.open()

    # ------------------------------------------------------------------ commands
    def transact(self, command: P.Command, policy: Optional[RetryPolicy] = None) -> P.Reply:
        """Send `command` and return its parsed reply (with the retry policy, or `policy` for this one)."""
        self.send(command)
        return self.finish(policy)

    def cancel(self) -> None:
        """Give up on the pending command (if any): its reply, if it still comes, will be discarded."""
        if self._pending is not None:
            if self._port is not None and self._sent:
                self._abandon(self._pending)
            self._pending = None

    def send(self, command: P.Command) -> None:
        """Put `command` on the line; its reply is read by :meth:`finish`.  Write errors are retried there."""
        if self._pending is not None:
            raise RuntimeError(f"robot {self.name!r}: command {self._pending.text!r} still waits for its reply")
        if self._port is None:
            raise LinkError(self.name, command.text, "link is closed")
        self._pending = command
        self.stats.commands += 1
        self._t_sent = time.monotonic()
        self._sent = self._write(command)

    def finish(self, policy: Optional[RetryPolicy] = None) -> P.Reply:
        """Read the reply to the pending command, resending on timeout and reopening a dropped link."""
        policy = policy or self.policy
        command = self._pending
        if command is None:
            raise RuntimeError(f"robot {self.name!r}: finish() without a pending command")
        reconnects = 0
        attempt = 1
        done = False
        try:
            while True:
                try:
                    if not self._sent:
                        raise ConnectionError("write failed")
                    reply = self._read_reply(command, time.monotonic() + policy.timeout)
                    done = True
                    self.stats.last_round_trip = time.monotonic() - self._t_sent
                    return reply
                except _NoLine:
                    self._abandon(command)
                    if attempt >= policy.attempts:
                        raise RobotTimeout(self.name, command.text,
                                           f"no reply within {policy.timeout:g} s on {attempt} attempt(s) "
                                           f"({self.url})") from None
                    attempt += 1
                    self.stats.retries += 1
                except _link_errors() + (ConnectionError,) as exc:
                    if reconnects >= policy.reconnects:
                        raise LinkError(self.name, command.text, f"link to {self.url} failed: {exc}") from exc
                    reconnects += 1
                    try:
                        self.reopen()
                    except LinkError as exc2:
                        raise LinkError(self.name, command.text,
                                        f"link to {self.url} failed ({exc}) and could not be reopened") from exc2
                if policy.backoff:
                    time.sleep(policy.backoff)
                self._buf.clear()
                self._flush_input()
                self._sent = self._write(command)
        finally:
            if not done and self._port is not None and self._sent:
                self._abandon(command)  # interrupted (Ctrl-C, error): its reply may still come
            self._pending = None

    # ------------------------------------------------------------------ internals
    def _abandon(self, command: P.Command) -> None:
        letter = P.REPLY_LETTER.get(command.letter)
        if letter is not None:
            self._stale[letter] = self._stale.get(letter, 0) + 1

    def _write(self, command: P.Command) -> bool:
        if self._port is None:
            return False
        try:
            self._port.write(command.encode(self.eol))
            self._port.flush()
            return True
        except _link_errors():
            return False

    def _flush_input(self) -> None:
        try:
            if self._port is not None:
                self._port.reset_input_buffer()
        except _link_errors():
            pass

    def _read_line(self, deadline: float) -> bytes:
        """One line up to and including its "\n" (so "\r\n" too); _NoLine when the deadline passes first."""
        while True:
            i = self._buf.find(b"\n")
            if i >= 0:
                line = bytes(self._buf[:i + 1])
                del self._buf[:i + 1]
                return line
            if len(self._buf) > MAX_LINE:
                line = bytes(self._buf)
                self._buf.clear()
                return line  # an over-long line: let the parser reject it
            if time.monotonic() > deadline:
                raise _NoLine()
            port = self._port
            if port is None:
                raise ConnectionError("link closed")
            waiting = getattr(port, "in_waiting", 0) or 0
            chunk = port.read(max(1, min(int(waiting), 4096)))
            if chunk:
                self._buf.extend(chunk)

    def _read_reply(self, command: P.Command, deadline: float) -> P.Reply:
        expected = P.REPLY_LETTER.get(command.letter)
        while True:
            raw = self._read_line(deadline)
            text = raw.rstrip(b"\r\n")
            if not text:
                continue  # the empty half of a "\r\n" split across reads, or a bare line end
            letter = chr(text[0]) if text[0] < 128 else ""
            if letter != expected and self._stale.get(letter, 0) > 0:
                # a late reply to an abandoned attempt of another command: check its shape, then drop it
                stale_cmd = next(c for c, r in P.REPLY_LETTER.items() if r == letter)
                P.parse_reply(raw, stale_cmd, self.name)
                self._stale[letter] -= 1
                self.stats.stale_replies += 1
                continue
            return P.parse_reply(raw, command, self.name)


def check_reply_type(reply: P.Reply, kind: type, link: RobotLink, command: P.Command) -> Any:
    if not isinstance(reply, kind):  # pragma: no cover - parse_reply already guarantees the type
        raise ProtocolError(link.name, command.text, f"expected a {kind.__name__} reply", reply=str(reply))
    return reply
