"""How often a called robot fails to come home, and stands still, in the training protocol with the generalisation
noise: 200 episodes of `plus` per champion, with the paper's signal (tick 690 of 1364) and a late one (tick 1980
of 3480).

Why: the sequential protocol's home misses are mostly deadlocks between the network and the reflex (README).  If
they happen in training episodes too, evolution meets them, and the question becomes how strongly a robust fitness
of a few noisy episodes selects against an event of a few percent.

Per robot: episodes in which it never came within 20 cm of home after the signal, and of those, the episodes in
which it moved less than 1 cm over the last 300 ticks (standing).

Usage: python docs/results/transfer_failures/deadlock_rate.py OUT.json CHAMPION.json ... [--episodes 200]
"""
from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

from mahn_envs import BatchSim
from mahn_envs.core.api import HOME_REACHED
from mahn_evo.evaluation.task_setup import task_params
from mahn_evo.training.champion import Champion

SIGNALS = ((690, 1364), (1980, 3480))
STAND_TICKS, STAND_CM = 300, 1.0


def measure(path: Path, episodes: int) -> dict:
    champ = Champion.load(path)
    rows = {}
    for signal, ticks in SIGNALS:
        sim = BatchSim("plus", episodes, params=task_params("generalization", signal_tick=signal, max_cycles=ticks))
        tr = sim.run_controllers(champ.controllers, seed=11, record=True).trajectories
        assert tr is not None
        home = sim.world.home
        miss = (np.abs(tr[:, signal:, :, 0] - home[0]) + np.abs(tr[:, signal:, :, 1] - home[1])).min(1) > HOME_REACHED
        last = tr[:, -STAND_TICKS:, :, :2]
        stand = np.hypot(last[..., 0] - last[:, -1:, :, 0], last[..., 1] - last[:, -1:, :, 1]).max(1) < STAND_CM
        rows[f"signal {signal}"] = {"home_misses": miss.sum(0).tolist(), "standing": (miss & stand).sum(0).tolist()}
        print(f"{path.name}: signal {signal}: home misses per robot {miss.sum(0).tolist()}, standing "
              f"{(miss & stand).sum(0).tolist()} of {episodes}", flush=True)
    return {"champion": str(path), "signals": rows}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("out", type=Path)
    ap.add_argument("champions", type=Path, nargs="+")
    ap.add_argument("--episodes", type=int, default=200)
    a = ap.parse_args()
    teams = [measure(p, a.episodes) for p in a.champions]
    a.out.write_text(json.dumps({"episodes": a.episodes, "map": "plus", "noise": "generalization", "episode_seed": 11,
                                 "teams": teams}, indent=1) + "\n")


if __name__ == "__main__":
    main()
