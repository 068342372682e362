"""Training throughput of the lean PPO methods (whole updates: rollout + PPO epochs) against the issue's targets,
and against SB3's PPO / RecurrentPPO as configured in `baselines/algos.py`, measured in the same run.

Robot-steps/s are given per wall second and per CPU second of this process (`time.process_time`): on a
shared machine the wall figure depends on the other load, the CPU figure much less.  torch runs on 1 thread.

    python benchmarks/bench_rl.py [--methods ppo_ff ippo_gru mappo_gru] [--episodes 32] [--updates 1]
                                  [--sb3-steps 49152]   # 0 skips SB3
"""
from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))  # this checkout's code

TARGETS = {"ppo_ff": 60_000, "ippo_gru": 20_000, "mappo_gru": 20_000}


def bench_lean(method: str, episodes: int, updates: int) -> tuple[float, float]:
    from baselines.lean_config import LeanConfig
    from baselines.lean_ppo import LeanPPO

    with tempfile.TemporaryDirectory() as out:
        cfg = LeanConfig(method=method, steps=10**12, n_episodes=episodes, eval_maps=["plus"])
        run = LeanPPO(cfg, os.path.join(out, "run"))
        run.learn(run.rollout())  # warm-up: first calls allocate and initialise
        c0, t0 = time.process_time(), time.perf_counter()
        for _ in range(updates):
            run.learn(run.rollout())
        n = updates * run.steps_per_update
        return n / (time.perf_counter() - t0), n / (time.process_time() - c0)


def bench_sb3(algo: str, steps: int) -> tuple[float, float]:
    import torch

    from baselines.algos import get_algo, resolved_hyperparams
    from baselines.vec_env import PatrolReturnVecEnv, register_with_sb3

    register_with_sb3()
    torch.set_num_threads(1)
    spec = get_algo(algo)
    env = PatrolReturnVecEnv(16, reward_scale=0.1)
    model = spec.model_class()(spec.policy, env, seed=0, device="cpu", verbose=0, **resolved_hyperparams(algo))
    c0, t0 = time.process_time(), time.perf_counter()
    model.learn(total_timesteps=steps)
    n = model.num_timesteps
    return n / (time.perf_counter() - t0), n / (time.process_time() - c0)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--methods", nargs="+", default=list(TARGETS), choices=list(TARGETS))
    ap.add_argument("--episodes", type=int, default=32, help="episodes per rollout (slots = x3)")
    ap.add_argument("--updates", type=int, default=1, help="timed updates per method (after one warm-up)")
    ap.add_argument("--sb3-steps", type=int, default=49152, help="robot-steps of each SB3 reference (0: skip)")
    a = ap.parse_args()
    print(f"load average before: {os.getloadavg()[0]:.2f} on {os.cpu_count()} cores")
    print(f"{'method':<16}{'robot-steps/s':>15}{'per CPU-s':>12}{'target':>9}  meets (CPU-s)")
    lean = {}
    for m in a.methods:
        wall, cpu = bench_lean(m, a.episodes, a.updates)
        lean[m] = cpu
        print(f"{m:<16}{wall:>15,.0f}{cpu:>12,.0f}{TARGETS[m]:>9,}  {'yes' if cpu >= TARGETS[m] else 'NO'}",
              flush=True)
    if a.sb3_steps > 0:
        refs = {"ppo": "ppo_ff", "recurrent_ppo": "ippo_gru"}
        for algo, ours in refs.items():
            wall, cpu = bench_sb3(algo, a.sb3_steps)
            ratio = f"{ours} / {algo} = {lean[ours] / cpu:.1f}x (CPU-s)" if ours in lean else ""
            print(f"sb3 {algo:<12}{wall:>15,.0f}{cpu:>12,.0f}{'':>9}  {ratio}", flush=True)
    print(f"load average after: {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
