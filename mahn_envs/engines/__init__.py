"""Engines that advance one episode: the kinematic core (default) and pymunk contact physics.

Both expose the same small interface over a one-episode BatchSim, so the env does not care which runs.
"""
from __future__ import annotations

from ..core import TaskParams
from ..khepera import DEFAULT_MODEL, KheperaModel
from ..maps import World
from .kinematic import KinematicEngine

ENGINES = ("kinematic", "pymunk")


def make_engine(name: str, world: World, params: TaskParams, model: KheperaModel = DEFAULT_MODEL,
                robots_collide: bool = False):
    if name == "kinematic":
        if robots_collide:
            raise ValueError("robots_collide=True needs engine='pymunk' (the kinematic core has no robot contacts)")
        return KinematicEngine(world, params, model)
    if name == "pymunk":
        from .pymunk_engine import PymunkEngine

        return PymunkEngine(world, params, model, robots_collide=robots_collide)
    raise ValueError(f"unknown engine {name!r}; choose one of {ENGINES}")
