"""The sequential (real-world) protocol: the batch core against the env-driven protocol, in one run.

  core    robot-steps/s of whole noisy sequential episodes of published teams in the compiled parallel loop
          (`mahn_envs.core.sequential.play_sequential`, a batch of teams, all cores): what `--sequential-episodes`
          costs evolution
  env     robot-steps/s of the same episodes through the PettingZoo env and ControllerPolicy
          (`sequential_episode(engine="kinematic")`, one episode at a time, as the transfer test plays them in pymunk)
  pymunk  the same in the pymunk engine (the transfer test itself)
  ratio   core / env

Both implementations give the same records (tests/envs/test_sequential_kernel.py), so the ratio is the speed-up of
scoring teams on the protocol.  Usage: python benchmarks/bench_sequential.py [--batch 300] [--repeats 3]
"""
from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(__file__), ".."))

from mahn_envs.core.sequential import play_sequential  # noqa: E402
from mahn_envs.policies.team_controllers import TeamControllers  # noqa: E402
from mahn_evo.evaluation.eval_champion import champion_policy  # noqa: E402
from mahn_evo.evaluation.protocols import sequential_episode  # noqa: E402
from mahn_evo.evaluation.task_setup import task_params  # noqa: E402
from mahn_evo.training.champion import Champion  # noqa: E402

DOCS = Path(__file__).parents[1] / "docs" / "results"
TEAMS = [DOCS / "experiment_fresh_seeds_lifetime" / "champions" / "situational_s029.json",
         DOCS / "experiment_lifetime_seeds_1_15" / "final_validation" / "champions" / "situational_s006.json"]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--batch", type=int, default=300, help="teams per core call (half robust, half brittle)")
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--env-episodes", type=int, default=4)
    args = ap.parse_args()
    champs = [Champion.load(p) for p in TEAMS]
    noisy = champs[0].task(task_params("generalization"))
    fields = ("w_ih", "w_hh", "w_ho", "b_h", "b_o")
    half = args.batch // 2
    batch = TeamControllers(*(np.concatenate([np.repeat(getattr(c.controllers, f)[None], n, axis=0)
                                              for c, n in zip(champs, (half, args.batch - half))]) for f in fields))
    keys = np.arange(args.batch)
    play_sequential("plus", batch, noisy, seed=1, episode_keys=keys)  # compile
    best, ticks = np.inf, 0
    for _ in range(args.repeats):
        t = time.perf_counter()
        out = play_sequential("plus", batch, noisy, seed=1, episode_keys=keys)
        best = min(best, time.perf_counter() - t)
        ticks = int(out.ticks.sum())
    core = 3 * ticks / best
    print(f"core    {core / 1e6:6.2f} M robot-steps/s  ({args.batch} episodes, {ticks / args.batch:.0f} ticks each, "
          f"{best:.2f} s)")
    rates = {}
    for engine in ("kinematic", "pymunk"):
        n_ticks, seconds = 0, 0.0
        for e in range(args.env_episodes):
            champ = champs[e % 2]
            t = time.perf_counter()
            res = sequential_episode(champion_policy(champ), params=noisy, seed=1 + e, engine=engine)
            seconds += time.perf_counter() - t
            n_ticks += res.ticks
        rates[engine] = 3 * n_ticks / seconds
        print(f"{'env' if engine == 'kinematic' else 'pymunk':7s} {rates[engine] / 1e3:8.1f} k robot-steps/s "
              f"({args.env_episodes} episodes, engine {engine})")
    print(f"ratio   {core / rates['kinematic']:6.0f}x  (core / env, same engine)")


if __name__ == "__main__":
    main()
