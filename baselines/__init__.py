"""RL baselines on the patrol-and-return task: PPO, RecurrentPPO and DQN with parameter sharing.

Importing this package (and `baselines.vec_env`) needs only numpy, gymnasium and the simulator; the training,
evaluation and comparison modules import torch / Stable-Baselines3 (the `rl` extra) when they are used.
"""
from __future__ import annotations

from .vec_env import PatrolReturnVecEnv, slot_observations

__all__ = ["PatrolReturnVecEnv", "slot_observations"]
