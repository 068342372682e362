"""Which part of the test map breaks which robot: noisy episodes of the training protocol with a late signal, on
`plus`, on plus maps that each take one part of `asymmetric_plus`, and on the test map itself.

Why: in the sequential protocol the robot sent left on `asymmetric_plus` most often fails to come home when
called (stages.py).  The test map differs from `plus` in three parts: a shorter left arm (48.43 cm, plus 78.74),
a longer top arm (118.11 cm) and a right arm that leaves the top arm 77.5 cm above the crossing (118.11 cm long).
Playing each part alone says which one the teams have not learnt.  The signal comes at tick 1980 (episodes of
3480 ticks), late enough for every robot to be at its post, as in the sequential protocol, where robots are called
after all have stopped.

Per robot: the fraction of episodes in which it is within 15 cm (Manhattan) of a post at the signal, and in which
it comes within the home radius after the signal.

Usage: python docs/results/transfer_failures/test_map_parts.py OUT.json CHAMPION.json ... [--episodes 40]
"""
from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

from mahn_envs import BatchSim
from mahn_envs.core.api import HOME_REACHED, POST_REACHED
from mahn_envs.maps import load_map
from mahn_envs.maps.variants import PLUS_ARM, plus_variant
from mahn_evo.evaluation.task_setup import task_params
from mahn_evo.training.champion import Champion

SIGNAL = 1980
TEST_LEFT, TEST_TOP, TEST_RIGHT, TEST_OFFSET = 48.43, 118.11, 118.11, 77.5


def maps() -> dict:
    """plus, each part of the test map alone, and the test map (the built-in one, not a rebuilt variant)."""
    return {"plus": load_map("plus"),
            "left arm 48.4": plus_variant(TEST_LEFT, PLUS_ARM, PLUS_ARM),
            "top arm 118.1": plus_variant(PLUS_ARM, TEST_TOP, PLUS_ARM),
            "right arm raised 77.5 (top 118.1)": plus_variant(PLUS_ARM, TEST_TOP, TEST_RIGHT, 0.0, TEST_OFFSET),
            "asymmetric_plus": load_map("asymmetric_plus")}


def measure(path: Path, episodes: int) -> dict:
    champ = Champion.load(path)
    params = task_params("generalization", signal_tick=SIGNAL, max_cycles=SIGNAL + 1500)
    rows = {}
    for name, world in maps().items():
        sim = BatchSim(world, episodes, params=params)
        tr = sim.run_controllers(champ.controllers, seed=5, record=True).trajectories
        assert tr is not None
        pois, home = sim.world.pois, sim.world.home
        at = tr[:, SIGNAL, :, :2]
        post = (np.abs(at[:, :, None, :] - pois[None, None]).sum(-1).min(-1) < POST_REACHED).mean(0)
        home_d = (np.abs(tr[:, SIGNAL:, :, 0] - home[0]) + np.abs(tr[:, SIGNAL:, :, 1] - home[1])).min(1)
        back = (home_d <= HOME_REACHED).mean(0)
        rows[name] = {"at_post": post.round(3).tolist(), "home_after_signal": back.round(3).tolist()}
        print(f"{path.name}: {name:36s} at a post {post.round(2).tolist()}  home {back.round(2).tolist()}", flush=True)
    return {"champion": str(path), "maps": rows}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("out", type=Path)
    ap.add_argument("champions", type=Path, nargs="+")
    ap.add_argument("--episodes", type=int, default=40)
    a = ap.parse_args()
    teams = [measure(p, a.episodes) for p in a.champions]
    a.out.write_text(json.dumps({"episodes": a.episodes, "signal_tick": SIGNAL, "noise": "generalization",
                                 "episode_seed": 5, "teams": teams}, indent=1) + "\n")


if __name__ == "__main__":
    main()
