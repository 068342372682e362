"""pymunk engine: robot-robot contact physics on top of the task's own rules.

Why this split: walls keep the task's revert-on-touch rule (so with robots apart this engine reproduces the
kinematic core, which the parity tests pin), while pymunk resolves what the core cannot: robots that bump into
and push each other, as in the real-world tests.  Sensing (including seeing other robots), the reflex and the
scoring are the core's, through BatchSim's split tick (`begin_tick`, `move_robot_to`, `end_tick`).
"""
from __future__ import annotations

import math

import numpy as np
import pymunk

from ..core import BatchSim, TaskParams
from ..core import task as T
from ..khepera import DEFAULT_MODEL, KheperaModel
from ..maps import World

ROBOT_MASS = 0.69  # kg, Khepera III


class PymunkEngine:
    name = "pymunk"

    def __init__(self, world: World, params: TaskParams, model: KheperaModel = DEFAULT_MODEL,
                 robots_collide: bool = False) -> None:
        self.sim = BatchSim(world, 1, params, model)
        self.robots_collide = robots_collide
        self.space = pymunk.Space()
        self.space.gravity = (0.0, 0.0)
        self.space.damping = 1.0
        self.bodies: list[pymunk.Body] = []
        for _ in range(self.sim.n_robots):
            body = pymunk.Body(ROBOT_MASS, pymunk.moment_for_circle(ROBOT_MASS, 0, model.radius))
            shape = pymunk.Circle(body, model.radius)
            shape.friction = 0.0
            shape.elasticity = 0.0
            if not robots_collide:
                shape.filter = pymunk.ShapeFilter(group=1)  # same group: never collide with each other
            self.space.add(body, shape)
            self.bodies.append(body)

    def _sync_bodies(self) -> None:
        pose = self.sim.pose[0]
        for r, body in enumerate(self.bodies):
            body.position = (float(pose[r, T.X]), float(pose[r, T.Y]))
            body.velocity = (0.0, 0.0)
            body.angle = float(pose[r, T.H])

    def reset(self, seed: int, poses: np.ndarray | None = None) -> np.ndarray:
        obs = self.sim.reset(seed=seed, poses=poses)[0]
        self._sync_bodies()
        return obs

    def step(self, actions: np.ndarray) -> tuple[np.ndarray, float, bool]:
        sim = self.sim
        sim.begin_tick(actions[None, :], validate=False)  # the clock, the actions and the reflex
        pose = sim.pose[0]
        old = pose[:, :2].copy()
        for r, body in enumerate(self.bodies):
            h, v = pose[r, T.H], pose[r, T.V]
            body.position = (float(old[r, 0]), float(old[r, 1]))
            body.velocity = (math.cos(h) * v, math.sin(h) * v)
            body.angular_velocity = 0.0
            body.angle = float(h)
        self.space.step(sim.model.dt_robot)
        for r, body in enumerate(self.bodies):
            x, y = body.position
            if not sim.move_robot_to(0, r, x, y):  # the core's wall rule: touching a wall undoes the move
                body.position = (float(old[r, 0]), float(old[r, 1]))
            body.velocity = (0.0, 0.0)
        obs, rewards, solved = sim.end_tick()  # fitness sample, signal, sensing for the next tick, reward
        return obs[0], float(rewards[0]), bool(solved[0])

    def close(self) -> None:
        for body in self.bodies:
            self.space.remove(body, *body.shapes)
        self.bodies.clear()
