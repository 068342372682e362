"""Fixtures: emulators and hardware envs that are always stopped and closed, bounded in time."""
from __future__ import annotations

import threading
import warnings

import pytest

from mahn_envs.hardware import KheperaEmulator, KheperaHardwareEnv, Link, Poses, RetryPolicy, Timing, VirtualClock


@pytest.fixture
def vclock():
    return VirtualClock()


@pytest.fixture
def make_emulator():
    started: list[KheperaEmulator] = []

    def make(n_robots: int = 3, **kwargs) -> KheperaEmulator:
        kwargs.setdefault("noise", 0.0)
        emu = KheperaEmulator(n_robots, **kwargs).start()
        started.append(emu)
        return emu

    yield make
    for emu in started:
        emu.stop(timeout=5.0)
        assert not emu.errors, emu.errors


@pytest.fixture
def make_env(make_emulator, vclock):
    """An env on a fresh lock-step emulator; returns (env, emulator).  Closed at teardown.  `env_kwargs` are the
    env's keywords (settings records); the emulator places and tracks the robots unless `placement` or
    `pose_source` replaces one of the two."""
    envs: list[KheperaHardwareEnv] = []

    def make(emu_kwargs: dict | None = None, placement=None, pose_source=None, **env_kwargs):
        emu_kwargs = dict(emu_kwargs or {})
        emu_kwargs.setdefault("clock", vclock)
        emu = make_emulator(**emu_kwargs)
        env_kwargs.setdefault("timing", Timing(clock=emu.world.clock))
        env_kwargs.setdefault("poses", Poses(placement=placement or emu.place, pose_source=pose_source or emu.poses))
        env_kwargs.setdefault("link", Link(retry=RetryPolicy(timeout=1.0, attempts=3)))
        env_kwargs.setdefault("catch_sigterm", False)
        env = KheperaHardwareEnv(emu.ports, **env_kwargs)
        envs.append(env)
        return env, emu

    yield make
    for env in envs:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # a test that leaves a robot silent has checked its warning already
            env.close()
        env.give_up_stops()  # a robot left silent on purpose: stop resending its stop


@pytest.fixture(autouse=True)
def no_leaked_threads():
    before = set(threading.enumerate())
    yield
    for t in threading.enumerate():
        if t not in before and t.name.startswith("khepera-stop"):
            t.join(2.0)  # a confirmed stop's thread may still be closing its link (pyserial waits 0.3 s)
    leaked = [t.name for t in threading.enumerate() if t not in before and t.is_alive()
              and t.name.startswith(("khepera-emulator", "khepera-stop"))]
    assert not leaked, f"emulator or stop threads left running: {leaked}"


def last_command(emu: KheperaEmulator, robot: int) -> str:
    cmds = emu.commands(robot)
    return cmds[-1] if cmds else ""
