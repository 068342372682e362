"""The emulator cannot be wedged or bloated by a client: idle clients are dropped, junk is capped in bytes, and a
non-loopback --host is refused with one line."""
from __future__ import annotations

import socket
import threading
import time

import pytest

from mahn_envs.cli import main as envs_main

pytestmark = pytest.mark.timeout(60)


def _connect(emu, k=0) -> socket.socket:
    host, port = emu.addresses[k]
    s = socket.create_connection((host, port), timeout=5.0)
    s.settimeout(5.0)
    return s


def _ask(s: socket.socket, line: bytes, expect: bytes) -> bytes:
    s.sendall(line)
    got = b""
    while expect not in got:
        chunk = s.recv(4096)
        assert chunk, f"connection closed; got {got!r}"
        got += chunk
    return got


def test_an_idle_client_does_not_hold_a_robot_port_forever(make_emulator):
    emu = make_emulator(idle_timeout=0.3)
    idle = _connect(emu)
    _ask(idle, b"B\n", b"b,")  # served, then silent
    other = _connect(emu)  # waits in the backlog behind the idle client ...
    t0 = time.monotonic()
    assert b"b,3,0" in _ask(other, b"B\n", b"\n")  # ... and is served once the idle one is dropped
    assert time.monotonic() - t0 < 5.0
    assert emu.idle_disconnects[0] == 1 and emu.connections[0] == 2
    assert idle.recv(16) == b""  # the idle client was disconnected
    idle.close()
    other.close()


def test_junk_input_is_capped_in_bytes(make_emulator):
    emu = make_emulator(log_bytes=20_000)
    s = _connect(emu)
    received = bytearray()

    def drain():  # read the `$` answers so the emulator never blocks on a full socket
        try:
            while True:
                chunk = s.recv(65536)
                if not chunk:
                    return
                received.extend(chunk)
                if b"b," in received:
                    return
        except OSError:
            return

    reader = threading.Thread(target=drain, daemon=True)
    reader.start()
    junk = (b"X" * 900 + b"\n") * 2000  # 1.8 MB of lines the robot rejects
    s.sendall(junk + b"Q" * 100_000)  # and 100 kB with no line end at all
    s.sendall(b"\nB\n")
    reader.join(30.0)
    s.close()
    assert b"b,3,0" in received and received.count(b"$") >= 2000
    log = emu.commands(0)
    assert log[-1] == "B"
    assert sum(len(line) + 1 for line in log) <= 20_000  # the log stays within its byte budget
    assert max(len(line) for line in log) <= 260  # a long line is logged truncated


def test_emulator_limits_are_validated():
    from mahn_envs.hardware import KheperaEmulator

    for bad in [dict(idle_timeout=0), dict(idle_timeout=-1.0), dict(log_bytes=10), dict(log_bytes=True)]:
        with pytest.raises(ValueError, match=next(iter(bad))):
            KheperaEmulator(1, **bad)


def test_a_non_loopback_host_is_refused_with_one_line(capsys):
    assert envs_main(["emulate", "--host", "0.0.0.0", "--port", "0", "--duration", "0.1"]) == 2
    err = capsys.readouterr().err
    assert "0.0.0.0" in err and "--allow-remote" in err and "Traceback" not in err
    assert len(err.strip().splitlines()) == 1
