from pathlib import Path

import numpy as np

from mahn_envs.policies.team_controllers import TeamControllers


def random_team(seed: int, n_brains: int = 2, scale: float = 1.5, n_robots: int = 3) -> TeamControllers:
    rng = np.random.default_rng(seed)
    R, K = n_robots, n_brains
    w_ih = rng.normal(0, scale, size=(R, K, 9, 7))
    if K == 2:
        w_ih[..., 6] = 0.0
    return TeamControllers(w_ih, rng.normal(0, scale, size=(R, K, 9, 9)), rng.normal(0, scale, size=(R, K, 3, 9)),
                           rng.normal(0, scale, size=(R, K, 9)), rng.normal(0, scale, size=(R, K, 3)))


_RESULTS = Path(__file__).parents[2] / "docs" / "results"
#: published teams for protocol tests: a lifetime-hardened one that passes the noisy sequential protocol (10/10 on
#: both maps) and one that fails most of it (2/10 on plus)
ROBUST_TEAM = _RESULTS / "experiment_fresh_seeds_lifetime" / "champions" / "situational_s029.json"
BRITTLE_TEAM = _RESULTS / "experiment_lifetime_seeds_1_15" / "final_validation" / "champions" / "situational_s006.json"
