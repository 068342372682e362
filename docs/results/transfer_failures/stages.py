"""Where champions fail the sequential (real-world) protocol with the generalisation noise: per robot, the first
stage it misses, on `plus` and `asymmetric_plus`, in blocks of 10 episodes from several episode seeds.

Why: the robustness target counts teams that succeed in at least 8 of 10 such episodes on both maps.  Which stage
fails says what the teams have not learnt; blocks from other seeds say how much a 10-episode count moves for the
same team.  A robot that misses coming home is counted as standing when it moved less than STAND_CM over the last
STAND_TICKS ticks of its call (a deadlock, see README), as wandering otherwise.

Usage: python docs/results/transfer_failures/stages.py OUT.json CHAMPION.json ... [--blocks 3] [--episodes 10]
       [--reflex {champion,original,arc}]
Block k uses episode seeds 1000 k .. 1000 k + episodes - 1.  --reflex: drive the teams with the reflex their file
records (default), or with the original's / the arcing reflex whatever they were evolved with (the deadlock test:
do the standing home misses go when the side branches drive?).
"""
from __future__ import annotations

import argparse
import collections
import json
from dataclasses import replace
from pathlib import Path

import numpy as np

from mahn_envs.policies.controller_policy import ControllerPolicy
from mahn_evo.evaluation.protocols import SequentialResult, sequential_episode
from mahn_evo.evaluation.task_setup import task_params
from mahn_evo.training.champion import Champion

MAPS = ("plus", "asymmetric_plus")
STAND_TICKS = 300
STAND_CM = 1.0


def first_missed(robot: dict) -> str | None:
    """The first of a robot's three stages it did not complete, or None."""
    for stage, key in (("post", "reached_post"), ("home", "returned_home"), ("out", "went_back_out")):
        if not robot[key]:
            return stage
    return None


def standing(result: SequentialResult, k: int) -> bool:
    """Whether robot k, called and not home, stayed within STAND_CM of where it ended its call for the last
    STAND_TICKS ticks of the call."""
    rec = result.robots[k]
    assert result.trajectory is not None and rec.call_end_tick is not None
    window = result.trajectory[max(0, rec.call_end_tick - STAND_TICKS):rec.call_end_tick, k, :2]
    return bool(np.hypot(*(window - window[-1]).T).max() < STAND_CM)


def measure(path: Path, blocks: int, episodes: int, reflex: str = "champion") -> dict:
    champ = Champion.load(path)
    agents = [f"robot_{k}" for k in range(champ.controllers.n_robots)]
    policy = ControllerPolicy(champ.controllers, agents)
    params = champ.task(task_params("generalization"))
    if reflex != "champion":
        params = replace(params, reflex_arc=reflex == "arc")
    out: dict = {"champion": str(path), "generation": champ.generation, "reflex_arc": params.reflex_arc, "maps": {}}
    for m in MAPS:
        counts, misses, stand = [], collections.Counter(), 0
        for k in range(blocks):
            results = [sequential_episode(policy, m, params, 1000 * k + e, record=True) for e in range(episodes)]
            counts.append(sum(r.success for r in results))
            for res in results:
                for i, r in enumerate(res.to_dict()["robots"]):
                    stage = first_missed(r)
                    if stage:
                        misses[f"{r['agent']}:{stage}"] += 1
                    if stage == "home" and standing(res, i):
                        stand += 1
        home = sum(v for key, v in misses.items() if key.endswith(":home"))
        out["maps"][m] = {"successes_per_block": counts, "episodes_per_block": episodes,
                          "first_missed_stage": dict(sorted(misses.items())), "home_misses_standing": stand}
        print(f"{path}: {m}: successes {counts} of {episodes} each; first missed stage {dict(sorted(misses.items()))}; "
              f"{stand} of {home} home misses standing", flush=True)
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("out", type=Path)
    ap.add_argument("champions", type=Path, nargs="+")
    ap.add_argument("--blocks", type=int, default=3)
    ap.add_argument("--episodes", type=int, default=10)
    ap.add_argument("--reflex", choices=("champion", "original", "arc"), default="champion")
    a = ap.parse_args()
    rows = [measure(p, a.blocks, a.episodes, a.reflex) for p in a.champions]
    a.out.write_text(json.dumps({"blocks": a.blocks, "episodes": a.episodes, "noise": "generalization",
                                 "reflex": a.reflex, "teams": rows}, indent=1) + "\n")


if __name__ == "__main__":
    main()
