"""One sequential episode of a champion with the generalisation noise, one robot's actions and poses over a window
of ticks: how a called robot that never comes home spends its time.

Usage: python docs/results/transfer_failures/trace_deadlock.py CHAMPION.json MAP EPISODE_SEED ROBOT FIRST LAST
e.g.   python docs/results/transfer_failures/trace_deadlock.py \\
           docs/results/experiment_fresh_seeds_one_short/champions/situational_s019.json plus 1 0 2200 2212
Each line: tick, the action the robot's network chose at it (L, F, R), and the robot's (x, y, heading) after it.
"""
from __future__ import annotations

import sys
from collections import Counter

from mahn_envs.policies.controller_policy import ControllerPolicy
from mahn_evo.evaluation.protocols import sequential_episode
from mahn_evo.evaluation.task_setup import task_params
from mahn_evo.training.champion import Champion


def main() -> None:
    if len(sys.argv) != 7:
        sys.exit(__doc__)
    path, map_name, seed, robot, first, last = sys.argv[1:]
    k, t0, t1 = int(robot), int(first), int(last)
    champ = Champion.load(path)
    agents = [f"robot_{i}" for i in range(champ.controllers.n_robots)]
    policy = ControllerPolicy(champ.controllers, agents)
    chosen: list[int] = []
    act = policy.act

    def logged(obs: dict) -> dict:
        actions = act(obs)
        chosen.append(int(actions[agents[k]]))
        return actions

    policy.act = logged  # type: ignore[method-assign]
    result = sequential_episode(policy, map=map_name, params=task_params("generalization"), seed=int(seed),
                                record=True)
    assert result.trajectory is not None
    print(f"{agents[k]}: {result.robots[k]}")
    print("actions over the window:", dict(Counter("LFR"[a] for a in chosen[t0:t1])))
    for t in range(t0, min(t1, len(chosen))):
        x, y, h = result.trajectory[t, k]
        print(f"{t:6d} {'LFR'[chosen[t]]} ({x:8.3f}, {y:8.3f}, {h:7.3f})")


if __name__ == "__main__":
    main()
