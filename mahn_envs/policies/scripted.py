"""A hand-written team that solves patrol-and-return: the task's reference behaviour.

Each robot follows waypoints (through the corridor centre lines) to its own POI, waits there until it
gets the signal, then retraces its route home.  It only uses the poses in `infos`, so it is a ground-truth
check of the task's rules and scoring (the original reaches ~163.9), not a learned policy.
"""
from __future__ import annotations

import math
from collections.abc import Mapping, Sequence

import numpy as np

from ..maps import World

LEFT, FORWARD, RIGHT = 0, 1, 2


def corridor_route(world: World, poi: int, trunk_x: float | None = None) -> list[tuple[float, float]]:
    """Waypoints from the start column to a POI for maps whose arms branch off a vertical trunk.

    Up the trunk (x = the start column's x) to the height of the POI, then straight to the POI.
    """
    x0 = float(world.starts[0, 0]) if trunk_x is None else trunk_x
    px, py = map(float, world.pois[poi])
    route = [(x0, py)] if abs(px - x0) > 1e-6 else []
    route.append((px, py))
    return route


class WaypointTeam:
    """Discrete actions that steer each robot along its waypoints (turn in place until aligned, then go).

    The signal picks the route: out to the POI without it, home with it (so an operator who clears a robot's
    signal at home sends it back out, as in the sequential protocol).  It steers from the poses in `infos`.
    """

    uses_infos = True

    def __init__(self, world: World, agents: Sequence[str], assignment: Sequence[int] | None = None,
                 tolerance: float = 2.0) -> None:
        n = len(agents)
        self.world = world
        self.agents = list(agents)
        self.assignment = list(assignment) if assignment is not None else [0, 2, 1][:n]
        if sorted(self.assignment) != list(range(len(world.pois)))[:n]:
            raise ValueError(f"assignment {self.assignment} must give each robot a different POI")
        self.tolerance = tolerance
        self.routes_out = [corridor_route(world, p) for p in self.assignment]
        home = (float(world.home[0]), float(world.home[1]))
        self.routes_back = [list(reversed(r[:-1])) + [home] for r in self.routes_out]
        self.reset()

    def reset(self) -> None:
        self.leg = {a: 0 for a in self.agents}
        self.returning = {a: False for a in self.agents}

    def _steer(self, pose: tuple[float, float, float], target: tuple[float, float]) -> int:
        x, y, h = pose
        desired = math.atan2(target[1] - y, target[0] - x)
        err = (desired - h + math.pi) % (2 * math.pi) - math.pi
        if abs(err) <= 0.0691:  # within one turning tick
            return FORWARD
        return LEFT if err > 0 else RIGHT

    def act(self, infos: Mapping[str, Mapping]) -> dict[str, int]:
        actions = {}
        for k, agent in enumerate(self.agents):
            if agent not in infos:
                continue
            info = infos[agent]
            if bool(info["signal"]) != self.returning[agent]:
                self.returning[agent] = bool(info["signal"])
                self.leg[agent] = 0
            route = self.routes_back[k] if self.returning[agent] else self.routes_out[k]
            x, y, _ = info["pose"]
            while self.leg[agent] < len(route) and math.dist((x, y), route[self.leg[agent]]) < self.tolerance:
                self.leg[agent] += 1
            if self.leg[agent] >= len(route):
                actions[agent] = LEFT  # arrived: wait turning in place (keeps `turned` true and the pose)
                continue
            actions[agent] = self._steer(info["pose"], route[self.leg[agent]])
        return actions


def run_scripted_episode(env, seed: int = 0, assignment: Sequence[int] | None = None,
                         freeze_after_signal: bool = False) -> tuple[float, bool, np.ndarray]:
    """Play one episode of the waypoint team in a PatrolReturnEnv; returns (fitness, solved, poses (T+1,R,3))."""
    obs, infos = env.reset(seed=seed)
    team = WaypointTeam(env.world, env.possible_agents, assignment)
    poses = [[infos[a]["pose"] for a in env.possible_agents]]
    last = infos
    while env.agents:
        actions = team.act(last)
        if freeze_after_signal and any(last[a]["signal"] for a in env.agents):
            actions = {a: LEFT for a in env.agents}
        obs, rewards, terms, truncs, last = env.step(actions)
        poses.append([last[a]["pose"] for a in env.possible_agents])
    info = last[env.possible_agents[0]]
    return info["team_fitness"], info["solved"], np.asarray(poses)
