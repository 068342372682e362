"""Where champions fail the sequential (real-world) protocol with the generalisation noise: per robot, the first
stage it misses, on `plus` and `asymmetric_plus`, in blocks of 10 episodes from several episode seeds.

Why: the robustness target counts teams that succeed in at least 8 of 10 such episodes on both maps.  Which stage
fails says what the teams have not learnt; blocks from other seeds say how much a 10-episode count moves for the
same team.

Usage: python docs/results/transfer_failures/stages.py OUT.json CHAMPION.json ... [--blocks 3] [--episodes 10]
Block k uses episode seeds 1000 k .. 1000 k + episodes - 1.
"""
from __future__ import annotations

import argparse
import collections
import json
from pathlib import Path

from mahn_envs.policies.controller_policy import ControllerPolicy
from mahn_evo.evaluation.protocols import sequential
from mahn_evo.evaluation.task_setup import task_params
from mahn_evo.training.champion import Champion

MAPS = ("plus", "asymmetric_plus")


def first_missed(robot: dict) -> str | None:
    """The first of a robot's three stages it did not complete, or None."""
    for stage, key in (("post", "reached_post"), ("home", "returned_home"), ("out", "went_back_out")):
        if not robot[key]:
            return stage
    return None


def measure(path: Path, blocks: int, episodes: int) -> dict:
    champ = Champion.load(path)
    agents = [f"robot_{k}" for k in range(champ.controllers.n_robots)]
    policy = ControllerPolicy(champ.controllers, agents)
    params = task_params("generalization")
    out: dict = {"champion": str(path), "generation": champ.generation, "maps": {}}
    for m in MAPS:
        counts, misses = [], collections.Counter()
        for k in range(blocks):
            res = sequential(policy, map=m, params=params, episodes=episodes, seed=1000 * k)
            counts.append(int(sum(res["solved"])))
            for ep in res["episodes"]:
                for r in ep["robots"]:
                    stage = first_missed(r)
                    if stage:
                        misses[f"{r['agent']}:{stage}"] += 1
        out["maps"][m] = {"successes_per_block": counts, "episodes_per_block": episodes,
                          "first_missed_stage": dict(sorted(misses.items()))}
        print(f"{path}: {m}: successes {counts} of {episodes} each; first missed stage {dict(sorted(misses.items()))}",
              flush=True)
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("out", type=Path)
    ap.add_argument("champions", type=Path, nargs="+")
    ap.add_argument("--blocks", type=int, default=3)
    ap.add_argument("--episodes", type=int, default=10)
    a = ap.parse_args()
    rows = [measure(p, a.blocks, a.episodes) for p in a.champions]
    a.out.write_text(json.dumps({"blocks": a.blocks, "episodes": a.episodes, "noise": "generalization",
                                 "teams": rows}, indent=1) + "\n")


if __name__ == "__main__":
    main()
