"""A Khepera III emulator: one TCP server per robot answering the ASCII protocol from the simulator.

``socket://127.0.0.1:<port>`` is what a network serial bridge (ser2net) in front of a real robot looks like to
pyserial, so the hardware env runs unchanged against it.  Each server serves one client at a time (a serial
line has one end); when a client goes away the robot keeps its last wheel speeds, as a real one would - only
the optional `watchdog` (robot-side safety, as in EPFL's Khepera III toolbox) stops it.

Faults can be injected per robot to test the host's error paths (:meth:`KheperaEmulator.inject`):
``drop`` (ignore the command, no reply), ``garbage`` (execute it, answer a corrupt line), ``delay`` (answer
late) and ``disconnect`` (close the connection without executing).  Every command line received is logged
with its robot time, so tests can check exactly which stop commands arrived.

Limits, so that no client can wedge or bloat it: a client that sends nothing for `idle_timeout` wall seconds
is disconnected (the port is free for the next one); input without a line end is dropped after 1024 bytes;
the command log keeps the newest lines within `log_bytes` bytes (each line logged at most 256 characters).
"""
from __future__ import annotations

import socket
import threading
import time
from collections import deque
from dataclasses import dataclass
from typing import Any

from . import protocol as P
from .emulated_world import EmulatedWorld

FAULT_KINDS = ("drop", "garbage", "delay", "disconnect")
GARBAGE = b"n,12#\x07?garbage,,\r\n"
LOOPBACK = ("127.0.0.1", "localhost", "::1")
MAX_PENDING_INPUT = 1024  # bytes without a line end before they are dropped as noise
MAX_LOGGED_LINE = 256  # characters of one command line kept in the log (the longest valid command is ~26)


@dataclass
class Fault:
    """Apply `kind` to the next `count` commands of robot `robot` whose letter is in `letters` (None = any).

    count None means forever.  `delay` is in wall seconds.
    """

    robot: int
    kind: str
    count: int | None = 1
    letters: str | None = None
    delay: float = 1.0
    hits: int = 0

    def __post_init__(self) -> None:
        if self.kind not in FAULT_KINDS:
            raise ValueError(f"unknown fault {self.kind!r}; known: {FAULT_KINDS}")
        if self.count is not None and (isinstance(self.count, bool) or int(self.count) < 1):
            raise ValueError(f"fault count must be a positive integer or None (forever), got {self.count!r}")
        if not self.delay >= 0:
            raise ValueError(f"fault delay must be >= 0 seconds, got {self.delay!r}")

    @property
    def active(self) -> bool:
        return self.count is None or self.hits < self.count

    def matches(self, robot: int, letter: str) -> bool:
        return self.active and robot == self.robot and (self.letters is None or letter in self.letters)


def parse_fault(spec: str) -> Fault:
    """``ROBOT:KIND[:COUNT[:LETTERS[:DELAY]]]`` e.g. ``1:drop:3:N``, ``0:delay:1:D:0.6``, ``2:disconnect``.
    COUNT may be ``forever``."""
    parts = spec.split(":")
    if len(parts) < 2 or len(parts) > 5:
        raise ValueError(f"fault spec {spec!r} must be ROBOT:KIND[:COUNT[:LETTERS[:DELAY]]]")
    try:
        robot = int(parts[0])
        count: int | None = 1
        if len(parts) > 2 and parts[2]:
            count = None if parts[2] == "forever" else int(parts[2])
        letters = parts[3] if len(parts) > 3 and parts[3] else None
        delay = float(parts[4]) if len(parts) > 4 else 1.0
    except ValueError as exc:
        raise ValueError(f"fault spec {spec!r}: {exc}") from None
    return Fault(robot, parts[1], count, letters, delay)


class KheperaEmulator:
    """`n_robots` protocol servers over one :class:`EmulatedWorld`.  Use as a context manager.

    ``port=0`` picks free ports; otherwise robot k listens on ``port + k``.
    """

    def __init__(self, n_robots: int = 3, *, host: str = "127.0.0.1", port: int = 0,
                 world: EmulatedWorld | None = None, eol: str = "\r\n", allow_remote: bool = False,
                 idle_timeout: float | None = 60.0, log_bytes: int = 4_000_000, **world_kwargs: Any) -> None:
        if host not in LOOPBACK and not allow_remote:
            raise ValueError(f"the emulator binds loopback only unless allow_remote=True (got host {host!r})")
        if not 0 <= int(port) <= 65535:
            raise ValueError(f"port must be in 0..65535, got {port!r}")
        if idle_timeout is not None and not (isinstance(idle_timeout, (int, float)) and idle_timeout > 0):
            raise ValueError(f"idle_timeout must be a positive number of seconds or None, got {idle_timeout!r}")
        if isinstance(log_bytes, bool) or not isinstance(log_bytes, int) or log_bytes < 1024:
            raise ValueError(f"log_bytes must be an integer >= 1024, got {log_bytes!r}")
        self.world = world if world is not None else EmulatedWorld(n_robots=n_robots, **world_kwargs)
        if self.world.n_robots != n_robots:
            raise ValueError(f"world has {self.world.n_robots} robots, emulator asked for {n_robots}")
        self.n_robots = n_robots
        self.host = host
        self.base_port = int(port)
        self.eol = eol
        self._faults: list[Fault] = []
        self._faults_lock = threading.Lock()
        self._stop = threading.Event()
        self._listeners: list[socket.socket] = []
        self._threads: list[threading.Thread] = []
        self._conns: list[socket.socket | None] = [None] * n_robots
        self.idle_timeout = idle_timeout
        self.log_bytes = log_bytes
        self._log: list[deque] = [deque() for _ in range(n_robots)]
        self._log_size = [0] * n_robots
        self.idle_disconnects = [0] * n_robots
        self.connections = [0] * n_robots
        self.errors: list[str] = []  # internal errors while answering (tests assert there are none)
        self.addresses: list[tuple[str, int]] = []

    # ------------------------------------------------------------------ lifecycle
    def start(self) -> KheperaEmulator:
        if self._threads:
            return self
        try:
            for k in range(self.n_robots):
                family = socket.AF_INET6 if ":" in self.host else socket.AF_INET
                s = socket.socket(family, socket.SOCK_STREAM)
                s.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
                s.bind((self.host, 0 if self.base_port == 0 else self.base_port + k))
                s.listen(1)
                s.settimeout(0.05)
                self._listeners.append(s)
                self.addresses.append(s.getsockname()[:2])
        except OSError:
            self.stop()
            raise
        for k in range(self.n_robots):
            t = threading.Thread(target=self._serve, args=(k,), name=f"khepera-emulator-{k}", daemon=True)
            self._threads.append(t)
            t.start()
        return self

    def stop(self, timeout: float = 5.0) -> None:
        """Stop serving and join the threads (bounded by `timeout` seconds in all)."""
        self._stop.set()
        for c in list(self._conns):
            _close(c)
        deadline = time.monotonic() + timeout
        for t in self._threads:
            t.join(max(0.0, deadline - time.monotonic()))
        for s in self._listeners:
            _close(s)
        self._listeners.clear()
        alive = [t.name for t in self._threads if t.is_alive()]
        self._threads.clear()
        if alive:
            raise RuntimeError(f"emulator threads did not stop: {alive}")

    def __enter__(self) -> KheperaEmulator:
        return self.start()

    def __exit__(self, *exc: Any) -> None:
        self.stop()

    @property
    def ports(self) -> list[str]:
        """pyserial URLs of the robots, in robot order."""
        return [f"socket://{h if ':' not in h else '[' + h + ']'}:{p}" for h, p in self.addresses]

    # ------------------------------------------------------------------ faults and inspection
    def inject(self, robot: int, kind: str, count: int | None = 1, letters: str | None = None,
               delay: float = 1.0) -> Fault:
        fault = Fault(robot, kind, count, letters, delay)
        if not 0 <= robot < self.n_robots:
            raise ValueError(f"no emulated robot {robot}")
        with self._faults_lock:
            self._faults.append(fault)
        return fault

    def add_fault(self, fault: Fault) -> Fault:
        return self.inject(fault.robot, fault.kind, fault.count, fault.letters, fault.delay)

    def clear_faults(self) -> None:
        with self._faults_lock:
            self._faults.clear()

    def commands(self, robot: int) -> list[str]:
        """Command lines robot `robot` received, oldest first."""
        return [line for _, line in list(self._log[robot])]

    def command_log(self, robot: int) -> list[tuple[float, str]]:
        return list(self._log[robot])

    def poses(self):
        return self.world.poses()

    def place(self, poses) -> None:
        self.world.place(poses)

    # ------------------------------------------------------------------ serving
    def _take_fault(self, robot: int, letter: str) -> Fault | None:
        with self._faults_lock:
            for f in self._faults:
                if f.matches(robot, letter):
                    f.hits += 1
                    return f
        return None

    def _serve(self, k: int) -> None:
        listener = self._listeners[k]
        while not self._stop.is_set():
            try:
                conn, _ = listener.accept()
            except TimeoutError:
                continue
            except OSError:
                return
            conn.settimeout(0.05)
            conn.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
            self._conns[k] = conn
            self.connections[k] += 1
            try:
                self._handle(k, conn)
            finally:
                self._conns[k] = None
                _close(conn)

    def _handle(self, k: int, conn: socket.socket) -> None:
        buf = bytearray()
        last_input = time.monotonic()
        while not self._stop.is_set():
            try:
                chunk = conn.recv(4096)
            except TimeoutError:
                if self.idle_timeout is not None and time.monotonic() - last_input > self.idle_timeout:
                    self.idle_disconnects[k] += 1
                    return  # an idle client must not hold the robot's port forever
                continue
            except OSError:
                return
            if not chunk:
                return  # client closed
            last_input = time.monotonic()
            buf.extend(chunk)
            while True:
                cut = min((i for i in (buf.find(b"\n"), buf.find(b"\r")) if i >= 0), default=-1)
                if cut < 0:
                    if len(buf) > MAX_PENDING_INPUT:
                        buf.clear()  # no line end in sight: drop the noise, as kh3server's line buffer would
                    break
                line = bytes(buf[:cut])
                del buf[:cut + 1]
                if not line:
                    continue
                try:
                    reply = self._process(k, line)
                except Exception as exc:  # noqa: BLE001 - a bug here must not kill the robot's server
                    self.errors.append(f"robot {k}, command {line!r}: {type(exc).__name__}: {exc}")
                    reply = P.format_error(self.eol)
                if reply is _CLOSE:
                    return
                if reply:
                    try:
                        conn.sendall(reply)
                    except OSError:
                        return

    def _process(self, k: int, line: bytes) -> Any:
        text = line.decode("ascii", errors="replace")
        world = self.world
        t = world.command_received(k)
        self._record(k, t, text)
        letter = text[:1]
        fault = self._take_fault(k, letter)
        if fault is not None:
            if fault.kind == "drop":
                return None
            if fault.kind == "disconnect":
                return _CLOSE
            if fault.kind == "delay":
                self._stop.wait(fault.delay)
        reply = self._execute(k, text)
        if fault is not None and fault.kind == "garbage":
            return GARBAGE
        return reply

    def _record(self, k: int, t: float, text: str) -> None:
        """Log a command line, keeping the newest lines within `log_bytes` (junk must not grow memory)."""
        if len(text) > MAX_LOGGED_LINE:
            text = text[:MAX_LOGGED_LINE] + "..."
        log = self._log[k]
        log.append((t, text))
        self._log_size[k] += len(text) + 1
        while self._log_size[k] > self.log_bytes and log:
            self._log_size[k] -= len(log.popleft()[1]) + 1

    def _execute(self, k: int, text: str) -> bytes:
        eol = self.eol
        world = self.world
        try:
            cmd = P.parse_command(text)
        except ValueError:
            return P.format_error(eol)
        L = cmd.letter
        if L == "B":
            return P.format_version(*world.firmware, eol=eol)
        if L == "M":
            world.init_motors(k)
            return P.format_ack("m", eol)
        if L == "D":
            world.set_speeds(k, *P.speeds_of(cmd))
            return P.format_ack("d", eol)
        if L == "E":
            return P.format_speeds(*world.speeds(k), eol=eol)
        if L == "N":
            values = world.proximity(k)
            return P.format_sensors("n", values, world.timestamp(k), eol)
        if L == "O":
            values = world.ambient(k)
            return P.format_sensors("o", values, world.timestamp(k), eol)
        if L == "Z":
            world.reset_timestamp(k)
            return P.format_ack("z", eol)
        return P.format_error(eol)


_CLOSE = object()


def _close(s: socket.socket | None) -> None:
    if s is None:
        return
    try:
        s.shutdown(socket.SHUT_RDWR)
    except OSError:
        pass
    try:
        s.close()
    except OSError:
        pass
