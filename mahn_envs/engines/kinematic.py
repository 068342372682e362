"""The default engine: the compiled batch core with one episode."""
from __future__ import annotations

import numpy as np

from ..core import BatchSim, TaskParams
from ..khepera import DEFAULT_MODEL, KheperaModel
from ..maps import World


class KinematicEngine:
    """Robots move exactly as in the original simulator: straight per tick, revert on touching a wall."""

    name = "kinematic"

    def __init__(self, world: World, params: TaskParams, model: KheperaModel = DEFAULT_MODEL) -> None:
        self.sim = BatchSim(world, 1, params, model)

    def reset(self, seed: int, poses: np.ndarray | None = None) -> np.ndarray:
        return self.sim.reset(seed=seed, poses=poses)[0]

    def step(self, actions: np.ndarray) -> tuple[np.ndarray, float, bool]:
        obs, rew, solved = self.sim.step(actions[None, :], validate=False)
        return obs[0], float(rew[0]), bool(solved[0])

    def close(self) -> None:
        pass
