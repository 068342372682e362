"""Simulator throughput, printed in one run so the ratios are comparable.

  core      robot-steps/s of whole episodes in the compiled loop (random team, population-sized batch,
            all cores), and with evolved-style controllers in the loop
  env       PettingZoo parallel env-steps/s for each engine (a Python loop of env.step, as users write it)
  ratio     core robot-steps/s / (env env-steps/s x 3 robots)

Targets on a 2-core machine: core >= 10M robot-steps/s; kinematic env >= 10k env-steps/s; pymunk env >= 2k.
Usage: python benchmarks/bench_sim.py [--batch 500] [--repeats 3]
"""
from __future__ import annotations

import argparse
import os
import sys
import time

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(__file__), ".."))

from mahn_envs import BatchSim, patrol_return_v0  # noqa: E402
from mahn_envs.policies.team_controllers import TeamControllers  # noqa: E402


def random_teams(n: int, seed: int = 0) -> TeamControllers:
    rng = np.random.default_rng(seed)
    R, K = 3, 2
    w_ih = rng.normal(0, 1.5, (n, R, K, 9, 7))
    w_ih[..., 6] = 0
    return TeamControllers(w_ih, rng.normal(0, 1.5, (n, R, K, 9, 9)), rng.normal(0, 1.5, (n, R, K, 3, 9)),
                           rng.normal(0, 1.5, (n, R, K, 9)), rng.normal(0, 1.5, (n, R, K, 3)))


def best_of(fn, repeats: int) -> float:
    fn()  # compile / warm up
    times = []
    for _ in range(repeats):
        t = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t)
    return min(times)


def env_rate(engine: str, steps: int) -> float:
    env = patrol_return_v0.parallel_env(engine=engine)
    env.reset(seed=0)
    rng = np.random.default_rng(0)
    acts = rng.integers(0, 3, size=(steps, 3))
    agents = env.possible_agents
    env.step({a: 1 for a in agents})
    env.reset(seed=0)
    t = time.perf_counter()
    n = 0
    for i in range(steps):
        if not env.agents:
            env.reset(seed=i)
        env.step({a: int(acts[i, k]) for k, a in enumerate(agents)})
        n += 1
    return n / (time.perf_counter() - t)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--batch", type=int, default=500)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--env-steps", type=int, default=20000)
    args = ap.parse_args()
    import numba

    B = args.batch
    sim = BatchSim("plus", B)
    robot_steps = B * 3 * sim.params.max_cycles
    t_rand = best_of(lambda: sim.run_random(seed=1), args.repeats)
    teams = random_teams(B)
    t_ctrl = best_of(lambda: sim.run_controllers(teams, seed=1), args.repeats)
    core_rate = robot_steps / t_rand
    ctrl_rate = robot_steps / t_ctrl
    kin = env_rate("kinematic", args.env_steps)
    pym = env_rate("pymunk", max(2000, args.env_steps // 4))
    print(f"machine: {os.cpu_count()} cores, numba threads {numba.get_num_threads()}")
    print(f"core, random team, batch {B}: {core_rate / 1e6:8.2f} M robot-steps/s   (target >= 10M)")
    print(f"core, controllers in loop, batch {B}: {ctrl_rate / 1e6:8.2f} M robot-steps/s "
          f"({t_ctrl:.3f} s per {B} full episodes)")
    print(f"env kinematic: {kin:10.0f} env-steps/s   (target >= 10k)")
    print(f"env pymunk:    {pym:10.0f} env-steps/s   (target >= 2k)")
    print(f"ratio core / kinematic env loop (robot-steps): {core_rate / (kin * 3):8.1f}x")
    print(f"ratio core / pymunk env loop (robot-steps):    {core_rate / (pym * 3):8.1f}x")


if __name__ == "__main__":
    main()
