"""Throughput of `PatrolReturnVecEnv` vs the standard SuperSuit route over the PettingZoo env (one run).

Both give SB3 the same number of slots (episodes x 3 robots) and are stepped with the same pre-drawn random
actions, so the numbers are pure env cost (no policy).  Prints robot-steps/s of each and their ratio.

    python benchmarks/bench_vec_env.py [--episodes 16] [--ticks 2728]
"""
from __future__ import annotations

import argparse
import time

import numpy as np


def bench(venv, actions: np.ndarray) -> float:
    venv.reset()
    venv.step(actions[0])  # warm up (numba compile is cached, but first calls allocate)
    t0 = time.perf_counter()
    for a in actions:
        venv.step(a)
    return actions.shape[0] * actions.shape[1] / (time.perf_counter() - t0)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--episodes", type=int, default=16, help="parallel episodes (slots = x3)")
    ap.add_argument("--ticks", type=int, default=2728, help="vector steps to time (2 full episodes)")
    args = ap.parse_args()

    import supersuit as ss

    from baselines.vec_env import PatrolReturnVecEnv
    from mahn_envs import patrol_return_v0

    ours = PatrolReturnVecEnv(args.episodes)
    ours.seed(0)
    theirs = ss.concat_vec_envs_v1(ss.pettingzoo_env_to_vec_env_v1(patrol_return_v0.parallel_env()),
                                   args.episodes, num_cpus=0, base_class="stable_baselines3")
    actions = np.random.default_rng(0).integers(0, 3, (args.ticks, ours.num_envs))
    ss_rate = bench(theirs, actions[: max(1, args.ticks // 4)])  # SuperSuit is slow: a quarter of the steps
    our_rate = bench(ours, actions)
    theirs.close()
    print(f"slots: {ours.num_envs} ({args.episodes} episodes x 3 robots)")
    print(f"PatrolReturnVecEnv : {our_rate:12,.0f} robot-steps/s")
    print(f"SuperSuit (PZ env) : {ss_rate:12,.0f} robot-steps/s")
    print(f"ratio              : {our_rate / ss_rate:12.1f} x")


if __name__ == "__main__":
    main()
