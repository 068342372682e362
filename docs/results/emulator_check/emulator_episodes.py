"""Published champions driven through the emulated Khepera IIIs, the code path of real robots.

Each champion plays the training protocol on `plus` through `KheperaHardwareEnv` against `KheperaEmulator` in
lock-step (a shared VirtualClock: every tick exactly 33 ms, so no timing jitter): once with the emulator's sensor
noise off (its counts are still 12-bit integers through the paper's calibration), and N times with a real sensor's
noise (emulator seeds 0..N-1).  One JSON line per champion.  The emulator has no motion noise and no start jitter.

Usage: python docs/results/emulator_check/emulator_episodes.py N CHAMPION.json ... > emulator.jsonl
"""
from __future__ import annotations

import json
import sys
from pathlib import Path

from mahn_envs.hardware import KheperaEmulator, KheperaHardwareEnv, Link, Poses, RetryPolicy, Timing, VirtualClock
from mahn_envs.policies.controller_policy import ControllerPolicy
from mahn_evo.training.champion import Champion

RESULTS = Path(__file__).resolve().parents[1]


def episode(champ: Champion, noise: float, seed: int) -> tuple[float, bool]:
    """Team fitness and solved of one emulated episode."""
    clock = VirtualClock()
    with KheperaEmulator(3, clock=clock, noise=noise, seed=seed) as emu, \
            KheperaHardwareEnv(emu.ports, timing=Timing(clock=clock),
                               poses=Poses(placement=emu.place, pose_source=emu.poses),
                               # the emulator compiles its sensing on the first N: a patient first reply
                               link=Link(retry=RetryPolicy(timeout=2.0))) as env:
        obs, infos = env.reset()
        policy = ControllerPolicy(champ.controllers, env.possible_agents)
        while env.agents:
            obs, _, _, _, infos = env.step(policy.act(obs))
        return float(infos["robot_0"]["team_fitness"]), bool(infos["robot_0"]["solved"])


def main() -> None:
    n = int(sys.argv[1])
    for path in sys.argv[2:]:
        champ = Champion.load(path)
        f0, s0 = episode(champ, 0.0, 0)
        res = [episode(champ, 1.0, s) for s in range(n)]
        name = str(Path(path).resolve().relative_to(RESULTS)) if Path(path).resolve().is_relative_to(RESULTS) else path
        print(json.dumps({"champion": name, "noise_free": [round(f0, 2), s0], "noisy_solved": sum(r[1] for r in res),
                          "noisy_episodes": n, "noisy_fitness": [round(r[0], 1) for r in res]}), flush=True)


if __name__ == "__main__":
    main()
