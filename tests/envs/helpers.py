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
