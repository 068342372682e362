"""`patrol_return_v0`: the three-robot patrol-and-return task as a PettingZoo ParallelEnv (and AEC).

A view of the batch core with one episode: the env only translates between PettingZoo's dicts and the
core's arrays, so it cannot disagree with the trainer or the RL vector env.
"""
from __future__ import annotations

import numbers
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
from gymnasium import spaces
from pettingzoo import ParallelEnv
from pettingzoo.utils import parallel_to_aec, wrappers

from ..core import TaskParams, policy_coordinates
from ..core import task as T
from ..core.params import ORIGINAL_MAX_TICKS, ORIGINAL_SIGNAL_TICK, check_flag
from ..core.rng import check_seed
from ..engines import make_engine
from ..khepera import DEFAULT_MODEL, KheperaModel
from ..maps import World, load_map

#: What each discrete action does (its index is the action), written once for error messages and users.
ACTION_MEANINGS = ("left", "forward", "right")
_ACTIONS_TEXT = ", ".join(f"{k} ({m})" for k, m in enumerate(ACTION_MEANINGS))


def agent_names(n: int) -> list[str]:
    return [f"robot_{k}" for k in range(n)]


def agent_policy_coordinates(agents: Sequence[str]) -> dict[str, float]:
    """{agent: z_k}: the policy-geometry coordinate of each agent, the one the trainer's substrate uses
    (core.api.policy_coordinates)."""
    return {a: float(z) for a, z in zip(agents, policy_coordinates(len(agents)))}


def coerce_action(agent: str, value: Any) -> int:
    """Accept ints, numpy integers and 0-d integer arrays in {0, 1, 2}; reject everything else by name."""
    if isinstance(value, np.ndarray) and value.shape == ():
        value = value.item()
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, numbers.Integral):
        raise ValueError(f"action for {agent!r} must be an integer {_ACTIONS_TEXT}, "
                         f"got {value!r} of type {type(value).__name__}")
    v = int(value)
    if not 0 <= v < len(ACTION_MEANINGS):
        raise ValueError(f"action for {agent!r} must be {_ACTIONS_TEXT}, got {v}")
    return v


def coerce_actions(actions: Any, live_agents: Sequence[str], possible_agents: Sequence[str]) -> list[int]:
    """A step's `{agent: action}` as ints in `live_agents` order; an unknown or missing agent, or a bad action,
    is a ValueError naming it.  Shared by the simulated and the hardware env, so both refuse the same input."""
    if not isinstance(actions, dict):
        raise ValueError(f"actions must be a dict {{agent: action}}, got {type(actions).__name__}")
    for agent in actions:
        if agent not in possible_agents:
            raise ValueError(f"action given for unknown agent {agent!r}; agents are {list(possible_agents)}")
    missing = [a for a in live_agents if a not in actions]
    if missing:
        raise ValueError(f"no action for agent(s) {missing}: every live agent must act each step")
    return [coerce_action(a, actions[a]) for a in live_agents]


def coerce_poses(poses: Any, possible_agents: Sequence[str]) -> dict[str, tuple[float, float, float]]:
    """`reset(options={"poses": {agent: (x, y, heading)}})` checked the same way by the simulated and the
    hardware env; whether a pose fits the map is the caller's check."""
    if not isinstance(poses, Mapping):
        raise ValueError("options['poses'] must be a dict {agent: (x, y, heading)}")
    out = {}
    for agent, pose in poses.items():
        if agent not in possible_agents:
            raise ValueError(f"options['poses'] names unknown agent {agent!r}; agents are {list(possible_agents)}")
        p = np.asarray(pose, dtype=np.float64)
        if p.shape != (3,):
            raise ValueError(f"pose for {agent!r} must be (x, y, heading), got {pose!r}")
        if not np.all(np.isfinite(p)):
            raise ValueError(f"pose for {agent!r} is not finite: {pose!r}")
        out[agent] = (float(p[0]), float(p[1]), float(p[2]))
    return out


def task_spaces(world: World, n: int) -> tuple[spaces.Box, spaces.Discrete, spaces.Box]:
    """The public contract's spaces, shared by the simulated and the hardware env.

    Observation Box(0, 1, (7,)) per agent, action Discrete(3) per agent, and the global state
    (x, y, heading, signal) of each of the n robots, robot-major.
    """
    xmin, ymin, xmax, ymax = world.bounds
    lo = np.tile(np.array([xmin, ymin, -np.inf, 0.0], dtype=np.float32), n)
    hi = np.tile(np.array([xmax, ymax, np.inf, 1.0], dtype=np.float32), n)
    return spaces.Box(0.0, 1.0, (7,), np.float32), spaces.Discrete(3), spaces.Box(lo, hi, dtype=np.float32)


class PatrolReturnEnv(ParallelEnv):
    """Khepera III robots patrol the arms of a plus maze, then come home when signalled.

    Observation (per agent): Box(0, 1, (7,)) = six IR inputs (index 0 leftmost; 1 = free, 0 = very close),
    then the come-home signal.  Action: Discrete(3) = 0 left, 1 forward (with the collision-avoidance
    reflex), 2 right.  The team reward is shared; an agent's rewards sum to the team fitness of the
    original paper (> 100 iff `solved`).
    """

    metadata: dict[str, Any] = {"name": "patrol_return_v0", "render_modes": ["human", "rgb_array"], "render_fps": 30,
                "is_parallelizable": True}

    def __init__(self, map: str | World = "plus", engine: str = "kinematic", robots_see_each_other: bool = False,
                 robots_collide: bool = False, sensor_noise: float = 0.0, effector_noise: float = 0.0,
                 heading_noise: float = 0.0, start_jitter_xy: float = 0.0, start_jitter_heading: float = 0.0,
                 max_cycles: int = ORIGINAL_MAX_TICKS, signal_tick: int = ORIGINAL_SIGNAL_TICK,
                 auto_signal: bool = True, reflex: bool = True, reflex_arc: bool = False,
                 input_ceiling: float = 1.0, reflex_reads_noise: bool = False, sensor_model: str = "uniform",
                 render_mode: str | None = None,
                 model: KheperaModel = DEFAULT_MODEL) -> None:
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise ValueError(f"render_mode must be one of {self.metadata['render_modes']} or None, "
                             f"got {render_mode!r}")
        check_flag(robots_collide, "robots_collide")
        self.world = load_map(map)
        self.params = TaskParams(max_cycles=max_cycles, signal_tick=signal_tick, sensor_noise=sensor_noise,
                                 effector_noise=effector_noise, heading_noise=heading_noise,
                                 start_jitter_xy=start_jitter_xy, start_jitter_heading=start_jitter_heading,
                                 robots_see_each_other=robots_see_each_other, reflex=reflex,
                                 reflex_arc=reflex_arc, auto_signal=auto_signal, input_ceiling=input_ceiling,
                                 reflex_reads_noise=reflex_reads_noise, sensor_model=sensor_model)
        self.model = model
        self.engine_name = engine
        self.engine = make_engine(engine, self.world, self.params, model, robots_collide=robots_collide)
        self.sim = self.engine.sim
        self.render_mode = render_mode
        n = self.world.n_robots
        self.possible_agents = agent_names(n)
        self.agents: list[str] = []
        self.agent_index = {a: k for k, a in enumerate(self.possible_agents)}
        self.policy_coordinates = agent_policy_coordinates(self.possible_agents)
        self._obs_space, self._act_space, self.state_space = task_spaces(self.world, n)
        self._obs_spaces = {a: self._obs_space for a in self.possible_agents}
        self._act_spaces = {a: self._act_space for a in self.possible_agents}
        self._actions = np.zeros(n, dtype=np.int64)
        self._renderer = None
        self._seed_rng = np.random.default_rng()
        self.observation_spaces = self._obs_spaces
        self.action_spaces = self._act_spaces

    @property
    def max_cycles(self) -> int:
        return self.params.max_cycles

    @max_cycles.setter
    def max_cycles(self, value: int) -> None:
        """Episode length in ticks; settable (PettingZoo's API test sets it) and applied from the next step."""
        self.params = self.sim.set_params(max_cycles=value)

    # -------------------------------------------------------------- spaces (identical objects every call)
    def observation_space(self, agent: str) -> spaces.Box:
        return self._obs_spaces[agent]

    def action_space(self, agent: str) -> spaces.Discrete:
        return self._act_spaces[agent]

    # -------------------------------------------------------------- episode
    def reset(self, seed: int | None = None, options: dict | None = None):
        if seed is not None:
            seed = check_seed(seed, "seed")
            self._seed_rng = np.random.default_rng(seed)
            sim_seed = seed & 0x7FFFFFFFFFFFFFFF
        else:
            sim_seed = int(self._seed_rng.integers(0, 2**63 - 1))
        for i, a in enumerate(self.possible_agents):
            self._act_spaces[a].seed(None if seed is None else seed + 1 + i)
            self._obs_spaces[a].seed(None if seed is None else seed + 101 + i)
        options = dict(options or {})
        poses = options.pop("poses", None)
        if options:  # PettingZoo's API test passes arbitrary options: tolerate them, but say so
            import gymnasium

            gymnasium.logger.warn(f"ignoring unknown reset option(s) {sorted(options)}; known: ['poses']")
        pose_array = None
        if poses is not None:
            pose_array = self.sim.pose[0, :, :3].copy() if self.sim.started else self.world.starts.copy()
            pose_array[:] = self.world.starts
            for agent, p in coerce_poses(poses, self.possible_agents).items():
                pose_array[self.agent_index[agent]] = p
        obs = self.engine.reset(sim_seed, pose_array)
        self.agents = list(self.possible_agents)
        observations = {a: obs[k].copy() for k, a in enumerate(self.agents)}
        infos = {a: self._info(k) for k, a in enumerate(self.agents)}
        if self.render_mode == "human":
            self.render()
        return observations, infos

    def _info(self, k: int) -> dict[str, Any]:
        p = self.sim.pose[0, k]
        return {"pose": (float(p[0]), float(p[1]), float(p[2])), "signal": bool(self.sim.rflag[0, k, T.F_SIGNAL])}

    def step(self, actions: dict):
        if not self.agents:
            raise RuntimeError("step() called on a finished episode; call reset() first")
        for agent, action in zip(self.agents, coerce_actions(actions, self.agents, self.possible_agents)):
            self._actions[self.agent_index[agent]] = action
        obs, reward, solved = self.engine.step(self._actions)
        done = self.sim.tick >= self.max_cycles
        observations = {a: obs[k].copy() for k, a in enumerate(self.agents)}
        rewards = {a: reward for a in self.agents}
        terminations = {a: False for a in self.agents}
        truncations = {a: done for a in self.agents}
        infos = {a: self._info(k) for k, a in enumerate(self.agents)}
        if done:
            fitness = float(self.sim.prev_fit[0])
            for a in self.agents:
                infos[a]["team_fitness"] = fitness
                infos[a]["solved"] = bool(solved)
            self.agents = []
        if self.render_mode == "human":
            self.render()
        return observations, rewards, terminations, truncations, infos

    # -------------------------------------------------------------- operator signal (sequential protocols)
    def call_home(self, agent: str) -> None:
        """Give one robot the come-home signal now (use with auto_signal=False)."""
        self.sim.give_signal(0, self.agent_index[agent], True)

    def clear_signal(self, agent: str) -> None:
        self.sim.give_signal(0, self.agent_index[agent], False)

    def place(self, agent: str, pose: tuple[float, float, float]) -> np.ndarray:
        """Move one robot by hand mid-episode (operator protocols); returns its fresh observation."""
        k = self.agent_index[agent]
        poses = self.sim.pose[0:1, :, :3].copy()
        poses[0, k] = np.asarray(pose, dtype=np.float64)
        from ..core import validate_poses

        validate_poses(self.world, poses[0, k:k + 1], self.model.radius, 1)
        self.sim.pose[0, k, :3] = poses[0, k]
        self.sim.pose[0, k, T.V] = 0.0
        self.sim.resense()
        return self.sim.obs[0, k].copy()

    # -------------------------------------------------------------- global state, rendering
    def state(self) -> np.ndarray:
        """(x, y, heading, signal) of every robot, robot-major."""
        s = np.concatenate([self.sim.pose[0, :, :3], self.sim.rflag[0, :, T.F_SIGNAL:T.F_SIGNAL + 1]], axis=1)
        return s.astype(np.float32).reshape(-1)

    def render(self):
        from .rendering import render_env

        sim = self.sim
        return render_env(self, sim.pose[0, :, :3], sim.raw[0], sim.rflag[0, :, T.F_SIGNAL].astype(bool), sim.tick,
                          float(sim.prev_fit[0]))

    def close(self) -> None:
        if self._renderer is not None:
            self._renderer.close()
            self._renderer = None


def parallel_env(**kwargs) -> PatrolReturnEnv:
    return PatrolReturnEnv(**kwargs)


def raw_env(**kwargs):
    return parallel_to_aec(PatrolReturnEnv(**kwargs))


def env(**kwargs):
    """AEC version (PettingZoo's conversion plus the usual safety wrappers)."""
    aec = raw_env(**kwargs)
    aec = wrappers.AssertOutOfBoundsWrapper(aec)
    return wrappers.OrderEnforcingWrapper(aec)
