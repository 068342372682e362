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
All commands this package sends are idempotent set-points or reads, so resending is safe.

Which reply answers which command.  The line is FIFO: the robot answers the commands it receives one at a
time, in the order they arrived, at most once each.  A reply can be late (an abandoned attempt's answer
turning up while a later command waits) or missing (a lost command or reply).  The link therefore keeps a
queue of every write it made (each attempt, including writes that raised: they may have reached the robot),
oldest first, and attributes each reply line to the *oldest* queued write whose command has the reply's
letter (``$`` to the oldest write of any letter); older queued writes of other letters are popped as lost.
A reply belongs to the waiting command only when it is attributed to one of that command's own writes;
otherwise it is stale and dropped (``stats.stale_replies``).

Invariant: a reply attributed to write j answers a write made at or after j.  Proof: let the reply answer
write i.  Write i was queued when it was made, and leaves the queue only when a reply is attributed to it or
to a later write.  Every reply read before this one answers a write k < i (FIFO) and, by induction, was
attributed to a write at or before k, so none of them removed write i.  Hence write i is still queued, has
the reply's letter, and the oldest such write is at or before i.  Consequence for safety: a stop counts as
confirmed only when the reply is attributed to one of the stop's own writes, and nothing is written while a
command waits, so the answered write is a stop: the robot really received a stop.  The queue is never
cleared (not on a retry, not on a reopen: a serial device can still deliver an old reply after reopening) and
input is never flushed, because a forgotten write could let its late reply be attributed to a later
command; dropping a reply is safe, misattributing one is not.  A fragment of a line cut by a reopen cannot
pass for a reply either: a reply's letter is only ever its first character.
"""
from __future__ import annotations

import threading
import time
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

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

    #: 0.12 s (the original deployment read with 0.4 s): 3 attempts detect a silent robot in 0.36 s, so every
    #: reachable robot is stopped within 0.5 s of a fault; a reply 4 control ticks late is already a retry
    timeout: float = 0.12
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


#: Seconds a write may block before the link counts as failed.  Not the read polling step: a 10 ms write timeout
#: on a busy machine made a healthy socket link "fail" and reconnect mid-episode.
WRITE_TIMEOUT = 0.5


def open_url(url: str, timeout: float, baudrate: int) -> Any:
    """Open `url` with `timeout` as the read polling step (deadlines are the link's own) and WRITE_TIMEOUT."""
    if _serial is None:
        raise ImportError("the hardware env needs pyserial: pip install 'mahn[hardware]'")
    return _serial.serial_for_url(url, baudrate=baudrate, timeout=timeout, write_timeout=WRITE_TIMEOUT)


def _link_errors() -> tuple[type[Exception], ...]:
    errs: tuple[type[Exception], ...] = (OSError, EOFError)
    if _serial is not None:
        errs = errs + (_serial.SerialException,)
    return errs


@dataclass
class _Writes:
    """Consecutive writes of one command (its attempts) that no reply has been attributed to yet."""

    command_id: int
    letter: str | None  # the reply letter its command expects (None: no known reply)
    count: int


@dataclass
class RobotLink:
    """The line to one robot.  Not thread-safe: one link is driven by one thread at a time."""

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
        self._pending: P.Command | None = None
        self._pending_id = 0
        self._next_id = 0
        self._sent = False
        self._queue: deque[_Writes] = deque()  # writes not yet answered, oldest first (see the module doc)
        self._t_sent = 0.0

    # ------------------------------------------------------------------ open / close
    @property
    def is_open(self) -> bool:
        return self._port is not None

    @property
    def unanswered_writes(self) -> int:
        """Writes on this line that no reply has been attributed to yet (late replies may still come)."""
        return sum(w.count for w in self._queue)

    def open(self) -> RobotLink:
        if self._port is None:
            try:
                # a short per-read timeout: whole-line deadlines are enforced here, not by pyserial
                self._port = self.opener(self.url, min(self.policy.timeout, 0.01), self.baudrate)
            except _link_errors() as exc:
                raise LinkError(self.name, "(open)", f"cannot open {self.url!r}: {exc}") from exc
            self._buf.clear()  # a partial line of the old connection; the write queue is kept (module doc)
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
    def transact(self, command: P.Command, policy: RetryPolicy | None = None) -> P.Reply:
        """Send `command` and return its parsed reply (with the retry policy, or `policy` for this one)."""
        self.send(command)
        return self.finish(policy)

    def cancel(self) -> None:
        """Give up on the pending command (if any): its reply, if it still comes, will be dropped as stale."""
        self._pending = None

    def send(self, command: P.Command) -> None:
        """Put `command` on the line; its reply is read by :meth:`finish`.  Write errors are retried there."""
        if self._pending is not None:
            raise RuntimeError(f"robot {self.name!r}: command {self._pending.text!r} still waits for its reply")
        if self._port is None:
            raise LinkError(self.name, command.text, "link is closed")
        self._begin(command)
        self._sent = self._write(command)

    def finish(self, policy: RetryPolicy | None = None) -> P.Reply:
        """Read the reply to the pending command, resending on timeout and reopening a dropped link."""
        policy = policy or self.policy
        command = self._pending
        if command is None:
            raise RuntimeError(f"robot {self.name!r}: finish() without a pending command")
        reconnects = 0
        attempt = 1
        try:
            while True:
                try:
                    if not self._sent:
                        raise ConnectionError("write failed")
                    reply = self._read_reply(command, time.monotonic() + policy.timeout)
                    self.stats.last_round_trip = time.monotonic() - self._t_sent
                    return reply
                except _NoLine:
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
                self._sent = self._write(command)
        finally:
            self._pending = None  # its writes stay queued: a late reply to them is recognised as stale

    def transact_until_answered(self, command: P.Command, interval: float, cancelled: threading.Event,
                                on_error: Callable[[Exception], None] | None = None) -> P.Reply | None:
        """Send `command` and resend it every `interval` seconds, reopening the link as often as needed, until
        one of its own writes is answered (the reply is returned) or `cancelled` is set (None is returned).

        For stops that must get through: all resends are writes of this one command, so a late answer to any of
        them confirms it, however late it comes.  Errors (timeouts, garbage, a dead link) are passed to
        `on_error` and retried, never raised."""
        if not interval > 0:
            raise ValueError(f"interval must be > 0 seconds, got {interval!r}")
        self.cancel()
        self._begin(command)
        written = False
        try:
            while not cancelled.is_set():
                try:
                    if self._port is None:
                        self.open()
                    if written:
                        self.stats.retries += 1
                    written = True
                    if not self._write(command):
                        raise ConnectionError("write failed")
                    reply = self._read_reply(command, time.monotonic() + interval)
                    self.stats.last_round_trip = time.monotonic() - self._t_sent
                    return reply
                except _NoLine:
                    error: Exception = RobotTimeout(self.name, command.text,
                                                    f"no reply within {interval:g} s ({self.url})")
                    wait = 0.0
                except ProtocolError as exc:
                    error, wait = exc, interval
                except LinkError as exc:
                    error, wait = exc, interval
                except _link_errors() + (ConnectionError,) as exc:
                    error, wait = LinkError(self.name, command.text, f"link to {self.url} failed: {exc}"), interval
                    self.close()
                    self._pending = command
                if on_error is not None:
                    on_error(error)
                if wait:
                    cancelled.wait(wait)
            return None
        finally:
            self._pending = None

    # ------------------------------------------------------------------ internals
    def _begin(self, command: P.Command) -> None:
        self._next_id += 1
        self._pending, self._pending_id = command, self._next_id
        self.stats.commands += 1
        self._t_sent = time.monotonic()

    def _write(self, command: P.Command) -> bool:
        """Write one attempt of the pending command; it is queued first, since even a write that raises may
        have reached the robot."""
        if self._port is None:
            return False
        last = self._queue[-1] if self._queue else None
        if last is not None and last.command_id == self._pending_id:
            last.count += 1
        else:
            self._queue.append(_Writes(self._pending_id, P.REPLY_LETTER.get(command.letter), 1))
        try:
            self._port.write(command.encode(self.eol))
            self._port.flush()
            return True
        except _link_errors():
            return False

    def _attribute(self, letter: str) -> int | None:
        """The id of the command whose queued write the reply `letter` answers (None: no queued write fits).
        The oldest fitting write is consumed and older writes of other letters are popped as lost."""
        queue = self._queue
        if letter == P.ERROR_MARK:
            index = 0 if queue else -1
        else:
            index = next((i for i, w in enumerate(queue) if w.letter == letter), -1)
        if index < 0:
            return None
        for _ in range(index):
            queue.popleft()
        writes = queue[0]
        writes.count -= 1
        if writes.count == 0:
            queue.popleft()
        return writes.command_id

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
        while True:
            raw = self._read_line(deadline)
            text = raw.rstrip(b"\r\n")
            if not text:
                continue  # the empty half of a "\r\n" split across reads, or a bare line end
            letter = P.ERROR_MARK if text == P.ERROR_MARK.encode() else (chr(text[0]) if text[0] < 128 else "")
            owner = self._attribute(letter)
            if owner == self._pending_id:
                return P.parse_reply(raw, command, self.name)
            if owner is None:  # answers no write on this line: garbage, or a reply to nothing we sent
                P.parse_reply(raw, command, self.name)  # raises for a wrong letter or a malformed line
                raise ProtocolError(self.name, command.text, "a reply that no command on this line waits for",
                                    reply=text.decode("ascii", "replace"))
            if letter != P.ERROR_MARK:  # a late reply to an abandoned command: check its shape, then drop it
                P.parse_reply(raw, _COMMAND_OF_REPLY[letter], self.name)
            self.stats.stale_replies += 1


_COMMAND_OF_REPLY = {reply: command for command, reply in P.REPLY_LETTER.items()}
