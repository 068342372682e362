"""No compiled rule is compiled inside the control loop of real (or emulated) robots.

A numba function compiles at its first call: seconds with a cold cache (after an install or an update), tens of
milliseconds when loaded from the cache.  Inside the control loop that stalls a tick while the robots drive on their
last command, and in the emulator a reply can time out (seen: `mahn-evo deploy --emulate` failing on its first
run with "no reply within 0.12 s").  So the hardware env and the emulator compile every rule they call before
they connect (`KheperaHardwareEnv._compile_rules`, `Arena.compile_rules`, `ScoreKeeper.compile_rules`), and
`ControllerPolicy` its network when it is made.

The check runs in a fresh interpreter, where no other test has compiled anything yet: it counts each compiled
function's compiled versions after the set-up, after `reset` and after a whole episode (with the come-home signal
and a brain switch), and requires the counts to stay the same.  It also requires the set-up to have compiled
the rules the loop calls, so a probe that sees nothing cannot pass.
"""
from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]

PROBE = r"""
import json, sys
import numpy as np
from numba.core.registry import CPUDispatcher


def compiled():
    out = {}
    for name, mod in list(sys.modules.items()):
        if mod is None or name.split(".")[0] not in ("mahn_envs", "mahn_evo"):
            continue
        for value in vars(mod).values():
            if isinstance(value, CPUDispatcher):
                out[f"{value.py_func.__module__}.{value.py_func.__name__}"] = len(value.overloads)
    return out


def changed(a, b):
    return sorted(k for k in b if b[k] != a.get(k, 0))


from mahn_envs.hardware import Episode, KheperaEmulator, KheperaHardwareEnv, Poses, Timing, VirtualClock
from mahn_envs.policies.controller_policy import ControllerPolicy
from tests.envs.helpers import random_team

start = compiled()
clock = VirtualClock()
emu = KheperaEmulator(3, map="plus", clock=clock, seed=1).start()
env = KheperaHardwareEnv(emu.ports, timing=Timing(clock=clock), catch_sigterm=False,
                         poses=Poses(placement=emu.place, pose_source=emu.poses),
                         episode=Episode(max_cycles=60, signal_tick=30))
policy = ControllerPolicy(random_team(11, n_brains=2), env.possible_agents)
ready = compiled()
obs, infos = env.reset()
policy.reset()
after_reset = compiled()
while env.agents:
    obs, rewards, terms, truncs, infos = env.step(policy.act(obs))
end = compiled()
env.close()
emu.stop()
print(json.dumps({"set_up": changed(start, ready), "reset": changed(ready, after_reset),
                  "loop": changed(after_reset, end), "ticks": infos["robot_0"]["tick"]}))
"""


@pytest.mark.timeout(600)
def test_the_control_loop_compiles_nothing():
    res = subprocess.run([sys.executable, "-c", PROBE], cwd=ROOT, capture_output=True, text=True, timeout=580)
    assert res.returncode == 0, res.stderr[-3000:]
    report = json.loads(res.stdout.strip().splitlines()[-1])
    assert report["ticks"] == 60
    # the set-up compiled what the loop runs (the probe sees compilations) ...
    for rule in ("mahn_envs.core.task.score_tick", "mahn_envs.core.task.team_fitness",
                 "mahn_envs.core.task.steer", "mahn_envs.core.task.reflex_response",
                 "mahn_envs.core.task.wall_revert", "mahn_envs.core.geometry.cast_rays",
                 "mahn_envs.core.task.input_value", "mahn_envs.core.controller.network_action"):
        assert rule in report["set_up"], (rule, report)
    # ... and neither reset nor the ticks compile anything more
    assert report["reset"] == [] and report["loop"] == [], report
