"""Baselines on the patrol-and-return task: SB3's PPO, RecurrentPPO and DQN with parameter sharing, a lean
torch PPO family (IPPO and MAPPO with GRU actors, frame-stacked feed-forward PPO), and CMA-ES evolving the
substrate networks' weights directly (the direct-encoding control).

Importing this package (and `baselines.vec_env`) needs only numpy, gymnasium and the simulator; the training,
evaluation and comparison modules import torch / Stable-Baselines3 (the `rl` extra) when they are used.
"""
from __future__ import annotations

from .vec_env import PatrolReturnVecEnv, slot_observations

__all__ = ["PatrolReturnVecEnv", "slot_observations"]
