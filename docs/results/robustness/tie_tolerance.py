"""How fine are an evolved team's decisions?  Each champion's noise-free fitness on `plus` when outputs within
`eps` of the largest count as tied (forward, then left, win ties, as in the original's rule).

If its turns came from clear output margins, small tolerances would change nothing.  Measured, every published
champion falls to the all-forward team's level (about 2) at eps = 1e-7, about one float32 step below 1.0: its
turns are decided between a saturated output (1.0) and one a step below it (0.99999994).  Those can still be
firm decisions, since the net inputs behind them can be far apart, which is why the jitter probe of `mahn-evo eval
--margins` (on the same network state) and the noisy protocols, not the output values, measure robustness.

Usage: python docs/results/robustness/tie_tolerance.py CHAMPION.json [CHAMPION.json ...]
"""
from __future__ import annotations

import sys

import numpy as np

from mahn_envs.policies.controller_policy import ControllerPolicy
from mahn_evo.evaluation.task_setup import task_env, task_params
from mahn_evo.training.champion import Champion

TOLERANCES = (0.0, 1e-7, 1e-6, 1e-5, 1e-4, 1e-3)


class TolerantPolicy(ControllerPolicy):
    """A ControllerPolicy whose winner-take-all counts outputs within `eps` of the largest as tied."""

    def __init__(self, controllers, agents, eps: float) -> None:
        super().__init__(controllers, agents)
        self.eps = np.float32(eps)

    def _step(self, b: int, r: int) -> int:
        action = super()._step(b, r)
        if self.eps == 0.0:
            return action
        out = self._out[b, r]
        top = out.max()
        for candidate in (1, 0, 2):  # forward, left, right: the original's tie order
            if out[candidate] >= top - self.eps:
                return candidate
        return action


def noise_free_fitness(champion: Champion, eps: float, map: str = "plus") -> float:
    env = task_env(map, task_params("none"))
    obs, _ = env.reset(seed=0)
    policy = TolerantPolicy(champion.controllers, env.possible_agents, eps)
    infos: dict = {}
    while env.agents:
        obs, _, _, _, infos = env.step(policy.act(obs))
    return float(infos[env.possible_agents[0]]["team_fitness"])


if __name__ == "__main__":
    if len(sys.argv) < 2:
        raise SystemExit(__doc__)
    print("champion", *(f"eps={e:g}" for e in TOLERANCES), sep="\t")
    for path in sys.argv[1:]:
        champ = Champion.load(path)
        print(path, *(f"{noise_free_fitness(champ, e):.1f}" for e in TOLERANCES), sep="\t", flush=True)
