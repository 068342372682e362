"""Drive three emulated Khepera IIIs through the hardware env - the code path real robots use.

    python examples/hardware_emulator.py                      # scripted team, real time (45 s)
    python examples/hardware_emulator.py --time-scale 5       # 5x faster
    python examples/hardware_emulator.py --lockstep           # as fast as possible, exactly 33 ms ticks
    python examples/hardware_emulator.py --champion runs/s1/champion.json

The emulator (TCP servers on 127.0.0.1 speaking the Khepera III protocol) also plays the overhead camera, so
the run is scored with the task's fitness.  To use real robots instead, replace ``emu.ports`` by your
serial URLs and ``poses=Poses(placement=emu.place, pose_source=emu.poses)`` by ``Poses(placement="prompt")``
(see docs/hardware.md).
"""
from __future__ import annotations

import argparse
import json

import numpy as np

from mahn_envs.hardware import (
    KheperaEmulator,
    KheperaHardwareEnv,
    Link,
    Poses,
    RealClock,
    RetryPolicy,
    Timing,
    VirtualClock,
)
from mahn_envs.policies.controller_policy import ControllerPolicy
from mahn_envs.policies.scripted import WaypointTeam
from mahn_envs.policies.team_controllers import TeamControllers


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--champion", help="champion.json to run instead of the scripted team")
    ap.add_argument("--time-scale", type=float, default=1.0, help="robot seconds per wall second")
    ap.add_argument("--lockstep", action="store_true", help="virtual clock: every tick exactly 33 ms")
    ap.add_argument("--noise", type=float, default=1.0, help="IR noise relative to a real robot's")
    args = ap.parse_args()

    clock = VirtualClock() if args.lockstep else RealClock(args.time_scale)  # shared by the robots and the env
    with KheperaEmulator(3, clock=clock, noise=args.noise, seed=0) as emu, \
            KheperaHardwareEnv(emu.ports, timing=Timing(clock=clock),
                               poses=Poses(placement=emu.place, pose_source=emu.poses),
                               # the emulator compiles its sensing code on the first N (about a second):
                               # a patient timeout, where real robots use the default 0.12 s
                               link=Link(retry=RetryPolicy(timeout=2.0))) as env:
        print("robots at", ", ".join(emu.ports), "- firmware", env.firmware["robot_0"],
              f"speed unit {env.speed_units[0]} units per mm/s")
        obs, infos = env.reset()
        if args.champion:
            with open(args.champion) as f:
                team = TeamControllers.from_dict(json.load(f)["controllers"])
            policy = ControllerPolicy(team, env.possible_agents)
            act = lambda obs, infos: policy.act(obs)  # noqa: E731
        else:
            scripted = WaypointTeam(env.world, env.possible_agents)
            act = lambda obs, infos: scripted.act(infos)  # noqa: E731
        periods = []
        while env.agents:
            obs, rewards, terms, truncs, infos = env.step(act(obs, infos))
            info = infos["robot_0"]
            periods.append(info["period"])
            if info["tick"] % 150 == 0:
                print(f"tick {info['tick']:4d}  robot_0 at ({info['pose'][0]:6.1f}, {info['pose'][1]:6.1f})  "
                      f"signal {int(info['signal'])}  last command {info['command']}")
        p = np.asarray(periods)
        print(f"period: median {np.median(p) * 1000:.1f} ms, 99th percentile {np.percentile(p, 99) * 1000:.1f} ms,"
              f" {env.overruns} overruns; team fitness {info['team_fitness']:.2f}, solved {info['solved']}")


if __name__ == "__main__":
    main()
