"""Transfer-test protocols: how a team is scored beyond its training episode.

- `training`: the simulation protocol (all robots called at the signal tick, robots apart): the team fitness.
- `sequential`: the paper's real-world protocol in simulation, with robots that see and bump into each other
  (pymunk engine).  Once all robots have stopped at their posts, they are called home one at a time in the
  order they left; a robot that reaches home has its signal cleared and is placed at home facing the arena,
  and must go back out to its post; then the next one is called.  Success = every robot reached its own
  post, returned home on its call and went back out.

A policy is anything with `reset()` and `act({agent: obs}) -> {agent: action}` (ControllerPolicy, the RL
baselines' SB3TeamPolicy); a policy with `uses_infos = True` (the scripted team) is given the infos instead.
"""
from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field
from typing import Any

import numpy as np

from mahn_envs import patrol_return_v0
from mahn_envs.core import TaskParams
from mahn_envs.core.api import HOME_REACHED, POST_REACHED, manhattan
from mahn_envs.core.sequential import SequentialSettings, assign_posts, call_order, sequential_task, stopped
from mahn_envs.maps import World

__all__ = ["SequentialSettings", "RobotRecord", "SequentialResult", "sequential_episode", "sequential",
           "sequential_summary", "SEQUENTIAL_STAGES"]


@dataclass
class RobotRecord:
    agent: str
    left_tick: int | None = None
    called_tick: int | None = None  # the tick its come-home signal was given (None: never called)
    call_end_tick: int | None = None  # the tick it reached home, or the protocol stopped waiting
    #: called, not home, and standing still when the protocol stopped waiting: most such robots are deadlocked
    #: between their network and the reflex (docs/results/transfer_failures/)
    stood_when_called: bool = False
    post: int | None = None  # POI index it stopped at
    reached_post: bool = False
    returned_home: bool = False
    went_back_out: bool = False


@dataclass
class SequentialResult:
    success: bool
    stages_completed: int
    robots: list[RobotRecord] = field(default_factory=list)
    ticks: int = 0
    trajectory: np.ndarray | None = None  # (T, R, 3)

    @property
    def score(self) -> float:
        return self.stages_completed / (3 * max(1, len(self.robots)))

    def to_dict(self) -> dict[str, Any]:
        d = {"success": self.success, "stages_completed": self.stages_completed, "score": self.score,
             "ticks": self.ticks, "robots": [asdict(r) for r in self.robots]}
        return d


class _Runner:
    def __init__(self, policy, env, settings: SequentialSettings, record: bool, frame_every: int = 0) -> None:
        self.policy, self.env, self.s = policy, env, settings
        self.obs: dict = {}
        self.infos: dict = {}
        self.history: list[list[tuple[float, float, float]]] = []
        self.record = record
        self.frame_every = frame_every
        self.frames: list[np.ndarray] = []
        #: positions after the last stop_window + 1 ticks (core.sequential.stopped's ring)
        self.ring = np.zeros((settings.stop_window + 1, len(env.possible_agents), 2))

    def poses(self) -> list[tuple[float, float, float]]:
        return [self.infos[a]["pose"] for a in self.env.possible_agents]

    def tick(self) -> None:
        src = self.infos if getattr(self.policy, "uses_infos", False) else self.obs
        self.obs, _, _, _, self.infos = self.env.step(self.policy.act(src))
        self.history.append(self.poses())
        self.ring[len(self.history) % len(self.ring)] = [p[:2] for p in self.history[-1]]
        if self.frame_every and len(self.history) % self.frame_every == 0:
            self.frames.append(self.env.render())

    def stopped(self, k: int) -> bool:
        """core.sequential.stopped: robot k moved less than stop_distance over the last stop_window ticks."""
        return bool(stopped(self.ring, len(self.history), k, self.s.stop_window, float(self.s.stop_distance)))


def sequential_episode(policy, map: str | World = "plus", params: TaskParams | None = None, seed: int = 0,
                       settings: SequentialSettings | None = None, record: bool = False,
                       frames: list | None = None, frame_every: int = 10, engine: str = "pymunk") -> SequentialResult:
    """One episode of the sequential protocol; RGB frames (every `frame_every` ticks) go to `frames` if given.

    `engine` "pymunk" (the transfer test: robots bump into each other) or "kinematic" (the batch core's motion,
    robots pass through each other; what `core.sequential.run_sequential` plays, record for record)."""
    s = settings or SequentialSettings()
    task = sequential_task(params or TaskParams(), s)  # the env's sample_period is the default, as the task's
    env = patrol_return_v0.parallel_env(map=map, engine=engine, **({"robots_collide": True} if engine == "pymunk"
                                                                    else {}),
                                        render_mode="rgb_array" if frames is not None else None,
                                        **{k: v for k, v in task.to_dict().items() if k != "sample_period"})
    run = _Runner(policy, env, s, record, frame_every if frames is not None else 0)
    run.obs, run.infos = env.reset(seed=seed)
    policy.reset()
    agents = env.possible_agents
    starts = run.poses()
    records = [RobotRecord(a) for a in agents]
    world = env.world
    home = (float(world.home[0]), float(world.home[1]))

    def note_departures(t: int) -> None:
        for k, rec in enumerate(records):
            p = run.history[-1][k]
            if rec.left_tick is None and math.hypot(p[0] - starts[k][0], p[1] - starts[k][1]) > s.left_distance:
                rec.left_tick = t

    # 1. patrol until everyone has stopped (or time is up)
    for t in range(1, s.patrol_ticks + 1):
        run.tick()
        note_departures(t)
        if t >= s.min_patrol_ticks and all(run.stopped(k) for k in range(len(agents))):
            break
    post = np.zeros(len(agents), dtype=np.int64)
    reached = np.zeros(len(agents), dtype=np.bool_)
    assign_posts(np.array([p[:2] for p in run.history[-1]]), np.asarray(world.pois, dtype=np.float64), post,
                 reached)
    for k, rec in enumerate(records):
        rec.post, rec.reached_post = int(post[k]), bool(reached[k])
    # 2. call robots home one at a time, in the order they left
    order = np.zeros(len(agents), dtype=np.int64)
    call_order(np.array([-1 if r.left_tick is None else r.left_tick for r in records], dtype=np.int64), order)
    for k in (int(i) for i in order):
        rec, agent = records[k], agents[k]
        env.call_home(agent)
        rec.called_tick = len(run.history)
        for _ in range(s.return_ticks):
            run.tick()
            if manhattan(run.history[-1][k], home) <= HOME_REACHED:
                rec.returned_home = True
                break
        rec.call_end_tick = len(run.history)
        rec.stood_when_called = not rec.returned_home and run.stopped(k)
        env.clear_signal(agent)
        if not rec.returned_home:
            continue
        try:  # placed at home facing the arena; the robot's controller restarts its patrol brain
            env.place(agent, (home[0], home[1], math.pi / 2))
        except ValueError:
            pass  # home blocked by the walls of a user map: leave it where it is
        run.obs[agent] = env.sim.obs[0, k].copy()
        for _ in range(s.out_ticks):
            run.tick()
            if rec.post is not None and run.stopped(k) and \
                    manhattan(run.history[-1][k], world.pois[rec.post]) < POST_REACHED:
                rec.went_back_out = True
                break
    stages = sum(int(r.reached_post) + int(r.returned_home) + int(r.went_back_out) for r in records)
    success = all(r.reached_post and r.returned_home and r.went_back_out for r in records)
    if frames is not None:
        frames.extend(run.frames)
    env.close()
    return SequentialResult(success, stages, records, len(run.history),
                            np.asarray(run.history) if record else None)


#: What the sequential protocol counts as stages, three per robot, in the order they happen.
SEQUENTIAL_STAGES = ("reached its own post", "came home when called", "went back out to its post")


def sequential_summary(result: dict[str, Any], map: str) -> str:
    """The result of :func:`sequential` for people: per episode, success and stages done out of possible, and
    what a stage is (the numbers alone do not say)."""
    lines = [f"sequential protocol on {map}:"]
    for e, ep in enumerate(result["episodes"]):
        possible = len(SEQUENTIAL_STAGES) * len(ep["robots"])
        stood = [r["agent"] for r in ep["robots"] if r.get("stood_when_called")]
        lines.append(f"  episode {e}: {'success' if ep['success'] else 'fail'}, "
                     f"{ep['stages_completed']}/{possible} stages"
                     + (f"; called and standing still away from home: {', '.join(stood)}" if stood else ""))
    lines.append(f"  stages: {len(SEQUENTIAL_STAGES)} per robot: it " + ", it ".join(SEQUENTIAL_STAGES)
                 + "; success = every stage of every robot")
    return "\n".join(lines)


def sequential(policy, map: str | World = "plus", params: TaskParams | None = None, episodes: int = 1, seed: int = 0,
               settings: SequentialSettings | None = None) -> dict[str, Any]:
    """Per-episode results of the sequential protocol.  `fitness` is the fraction of stages completed."""
    results = [sequential_episode(policy, map, params, seed + e, settings) for e in range(episodes)]
    return {"fitness": [r.score for r in results], "solved": [r.success for r in results],
            "episodes": [r.to_dict() for r in results]}
