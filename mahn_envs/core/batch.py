"""BatchSim: B independent patrol-and-return episodes of R robots as arrays, stepped by compiled kernels.

This is the one implementation of the task.  The PettingZoo env is BatchSim with B = 1, the trainer's
evaluator runs a generation of teams through `run_controllers`, and the RL vector env steps B episodes at once.
"""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np

from ..khepera import DEFAULT_MODEL, KheperaModel
from ..maps import World, load_map, wall_clearance
from ..policies.team_controllers import TeamControllers
from . import kernels, sequential
from . import task as T
from .api import Arena
from .controller import transposed
from .geometry import touches_any_wall, wall_boxes
from .params import TaskParams
from .rng import check_seed


@dataclass
class RobotEpisodes:
    """Robot episodes (`BatchSim.run_robot_episodes`): samples[b, s, r] robot r's (x, y, heading) at fitness sample s
    of episode b, finals[b, r] at its end, robots[b] the bit mask of the robots that played."""

    samples: np.ndarray
    finals: np.ndarray
    robots: np.ndarray


@dataclass
class RunResult:
    """Outcome of whole episodes: team fitness and `solved` per episode; trajectories if recorded.

    trajectories[b, t, r] = (x, y, heading, action) after tick t (t = 0: start; action -1 there).
    """

    fitness: np.ndarray
    solved: np.ndarray
    collisions: np.ndarray
    trajectories: np.ndarray | None = None


def validate_poses(world: World, poses: np.ndarray, radius: float, n_robots: int) -> np.ndarray:
    """Check user-given poses: finite, inside the arena's extent and not overlapping a wall."""
    arr = np.asarray(poses, dtype=np.float64)
    if arr.shape[-2:] != (n_robots, 3):
        raise ValueError(f"poses must have shape (..., {n_robots}, 3) of (x, y, heading), got {arr.shape}")
    flat = arr.reshape(-1, n_robots, 3)
    xmin, ymin, xmax, ymax = world.bounds
    boxes = wall_boxes(world.walls)
    for e in range(flat.shape[0]):
        for r in range(n_robots):
            x, y, h = flat[e, r]
            if not (np.isfinite(x) and np.isfinite(y) and np.isfinite(h)):
                raise ValueError(f"pose of robot {r} is not finite: ({x}, {y}, {h})")
            if not (xmin <= x <= xmax and ymin <= y <= ymax):
                raise ValueError(f"pose of robot {r} ({x:.3f}, {y:.3f}) lies outside map {world.name!r} "
                                 f"[{xmin}, {xmax}] x [{ymin}, {ymax}]")
            if touches_any_wall(float(x), float(y), radius, world.walls, boxes):
                raise ValueError(f"pose of robot {r} ({x:.3f}, {y:.3f}) overlaps a wall of map {world.name!r}")
    return arr


def check_start_jitter(world: World, params: TaskParams, radius: float) -> None:
    """Every start pose jittered by up to `start_jitter_xy` in x and y must keep the robot clear of the walls:
    a larger jitter would start robots inside walls or outside the arena."""
    j = float(params.start_jitter_xy)
    if j == 0.0:
        return
    for r, (x, y, _) in enumerate(world.starts):
        gap, w = wall_clearance(world.walls, float(x), float(y), j)
        if gap < radius:
            room, _ = wall_clearance(world.walls, float(x), float(y))
            raise ValueError(f"TaskParams.start_jitter_xy = {j:g} cm can put robot {r} into walls[{w}] of map "
                             f"{world.name!r} (its start is {room:.3g} cm from the nearest wall and the robot's "
                             f"radius is {radius:g} cm): use a smaller jitter")


#: at most this much memory for the sensor-Gaussian tables of one reset (BatchSim._share_sensor_gaussians)
GAUSS_TABLE_BYTES = 256 * 2**20


class BatchSim:
    """B episodes of the task in lock-step.  All randomness flows from the seed given to `reset`."""

    def __init__(self, world: World | str = "plus", n_episodes: int = 1, params: TaskParams | None = None,
                 model: KheperaModel = DEFAULT_MODEL) -> None:
        self.world = load_map(world)
        self.params = params if params is not None else TaskParams()
        self.model = model
        if isinstance(n_episodes, bool) or not isinstance(n_episodes, (int, np.integer)) or n_episodes < 1:
            raise ValueError(f"n_episodes must be a positive integer, got {n_episodes!r}")
        n_robots = self.world.n_robots
        n_pois = self.world.pois.shape[0]
        if n_pois != n_robots:
            raise ValueError(f"map {self.world.name!r} has {n_robots} start poses but {n_pois} POIs: the patrol "
                             "fitness (one POI per robot, as in the original) needs as many robots as POIs")
        check_start_jitter(self.world, self.params, model.radius)
        self.n_episodes = int(n_episodes)
        self.n_robots = n_robots
        self._pvec = self.params.vector(model)
        #: the map's geometry as the kernels read it (public: walls, boxes, sensor_dirs, pois, home)
        self.arena = Arena(self.world, model)
        B, R = self.n_episodes, n_robots
        self.pose = np.zeros((B, R, 4))
        self.raw = np.zeros((B, R, 6))
        self.obs = np.zeros((B, R, 7), dtype=np.float32)
        self.racc = np.zeros((B, R, 4))
        self.rflag = np.zeros((B, R, 3), dtype=np.uint8)
        self.goto = np.zeros((B, n_pois))
        self.est = np.zeros((B, 3), dtype=np.int64)
        self.prev_fit = np.zeros(B)
        self.rewards = np.zeros(B)
        self.solved = np.zeros(B, dtype=np.bool_)
        self.keys = np.arange(B, dtype=np.uint64)
        self.seed = 0
        # the kernels' argument groups (kernels.py describes them), built once around the arrays above
        self._state = (self.pose, self.raw, self.obs, self.racc, self.rflag, self.goto, self.est)
        self._geometry = (self.arena.walls, self.arena.boxes, self.arena.sensor_dirs, self.arena.pois,
                          self.arena.home)
        self._work = (np.zeros((B, R, 2)), np.full((B, R, 4), np.nan), np.zeros((B, R, 2)),
                      np.zeros((B, self.arena.walls.shape[0]), dtype=np.int64))
        self._scores = (self.prev_fit, self.rewards, self.solved)
        self._gauss = T.NO_GAUSSIANS
        self._gauss_rows = np.full(B, -1, dtype=np.int64)
        self._reset_done = False

    def set_params(self, **changes) -> TaskParams:
        """Replace some task parameters (validated); returns the new TaskParams."""
        params = replace(self.params, **changes)
        check_start_jitter(self.world, params, self.model.radius)
        self.params = params
        self._pvec = self.params.vector(self.model)
        kernels.forget_rays(self._work)
        return self.params

    def _kernel_seed(self) -> int:
        # the kernels take the seed as a 64-bit signed integer and mix it as uint64 (core.rng): seeds of 2**63 and
        # above are passed as the signed integer with the same bits
        return self.seed - 2**64 if self.seed >= 2**63 else self.seed

    def _task(self) -> tuple:
        """The kernels' `task` group: the parameter vector, the seed, the episode keys and the sensor Gaussians of
        shared keys (`_share_sensor_gaussians`)."""
        return (self._pvec, self._kernel_seed(), self.keys, self._gauss, self._gauss_rows)

    def _share_sensor_gaussians(self) -> None:
        """Under the "khepera" sensor model with noise, the Gaussians of every episode key that two or more
        episodes share, computed once into a table (kernels.fill_sensor_gaussians) that those episodes read
        instead of drawing their own: the same numbers, since a draw is a pure function of (seed, key, tick,
        robot, channel).  A trainer's batch plays all its teams on one key (common random numbers), so its
        episodes stop paying a Box-Muller pair per two sensors and tick (most of the robot noise's cost).  The
        tables of one reset take at most GAUSS_TABLE_BYTES (keys shared most first); other episodes draw their
        own, as do episodes beyond a table's ticks (after set_params lengthened them)."""
        self._gauss_rows[:] = -1
        p = self.params
        if p.sensor_model != "khepera" or p.sensor_noise <= 0.0 or self.n_episodes < 2:
            return
        keys, inverse, counts = np.unique(self.keys, return_inverse=True, return_counts=True)
        n_ticks = p.max_cycles + 2  # inputs are sensed for ticks 1 .. max_cycles + 1
        per_key = n_ticks * self.n_robots * 6 * 8
        shared = np.flatnonzero(counts >= 2)
        shared = shared[np.argsort(-counts[shared], kind="stable")][:GAUSS_TABLE_BYTES // per_key]
        if len(shared) == 0:
            return
        self._gauss = np.empty((len(shared), n_ticks, self.n_robots, 6))
        kernels.fill_sensor_gaussians(self._kernel_seed(), np.ascontiguousarray(keys[shared]), self._gauss)
        row_of_key = np.full(len(keys), -1, dtype=np.int64)
        row_of_key[shared] = np.arange(len(shared))
        self._gauss_rows[:] = row_of_key[inverse]

    # ------------------------------------------------------------------ episode control
    def start_poses(self, seed: int, episode_keys: np.ndarray) -> np.ndarray:
        """The map's start poses, jittered per episode when the params ask for it (deterministic per key)."""
        base = np.broadcast_to(self.world.starts, (len(episode_keys), self.n_robots, 3)).copy()
        jx, jh = self.params.start_jitter_xy, self.params.start_jitter_heading
        if jx > 0 or jh > 0:
            for e, key in enumerate(episode_keys):
                rng = np.random.default_rng([int(seed) & 0xFFFFFFFF, int(key) & 0xFFFFFFFF, 0x5EED])
                base[e, :, :2] += rng.uniform(-jx, jx, size=(self.n_robots, 2))
                base[e, :, 2] += rng.uniform(-jh, jh, size=self.n_robots)
        return base

    def reset(self, seed: int = 0, poses: np.ndarray | None = None,
              episode_keys: Sequence[int] | np.ndarray | None = None) -> np.ndarray:
        """Place the robots and sense; returns observations (B, R, 7).

        `episode_keys` name the episodes for the random streams (default 0..B-1): the same key and seed give
        the same noise whatever batch the episode runs in.
        """
        self.seed = check_seed(seed, "seed")
        if episode_keys is None:
            self.keys = np.arange(self.n_episodes, dtype=np.uint64)
        else:
            keys = np.asarray(episode_keys, dtype=np.int64)
            if keys.shape != (self.n_episodes,) or np.any(keys < 0):
                raise ValueError(f"episode_keys must be {self.n_episodes} non-negative integers")
            self.keys = keys.astype(np.uint64)
        if poses is None:
            start = self.start_poses(self.seed, self.keys)
        else:
            start = validate_poses(self.world, poses, self.model.radius, self.n_robots)
            start = np.broadcast_to(start, (self.n_episodes, self.n_robots, 3))
        self.pose[:] = 0.0
        self.pose[:, :, :3] = start
        self.raw[:] = 0.0
        self.obs[:] = 0.0
        self.racc[:] = 0.0
        self.rflag[:] = 0
        self.goto[:] = 0.0
        self.est[:] = 0
        self.prev_fit[:] = 0.0
        self.rewards[:] = 0.0
        self.solved[:] = False
        kernels.forget_rays(self._work)
        self._share_sensor_gaussians()
        kernels.sense_all(1, self._state, self._geometry, self._task(), self._work)
        self._reset_done = True
        return self.obs

    @property
    def tick(self) -> int:
        return int(self.est[0, T.E_TICK])

    @property
    def done(self) -> bool:
        return self.tick >= self.params.max_cycles

    def check_actions(self, actions: np.ndarray) -> np.ndarray:
        a = np.asarray(actions)
        if a.shape != (self.n_episodes, self.n_robots):
            raise ValueError(f"actions must have shape ({self.n_episodes}, {self.n_robots}), got {a.shape}")
        if a.dtype.kind not in "iu":
            if a.dtype.kind == "f" and np.all(np.isfinite(a)) and np.all(a == np.round(a)):
                a = a.astype(np.int64)
            else:
                raise ValueError(f"actions must be integers 0 (left), 1 (forward), 2 (right); got dtype {a.dtype}")
        if a.size and (a.min() < 0 or a.max() > 2):
            raise ValueError(f"actions must be 0 (left), 1 (forward) or 2 (right); got values {np.unique(a)}")
        return np.ascontiguousarray(a, dtype=np.int64)

    @property
    def started(self) -> bool:
        """True once `reset` has placed the robots (before that, `pose` holds no episode)."""
        return self._reset_done

    def _check_can_step(self) -> None:
        if not self._reset_done:
            raise RuntimeError("call reset() before step()")
        if self.done:
            raise RuntimeError(f"the episode is over (tick {self.tick} of {self.params.max_cycles}); call reset()")

    def step(self, actions: np.ndarray, validate: bool = True) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Advance every episode one tick.  Returns (obs (B,R,7), rewards (B,), solved (B,)).

        Rewards are the change of the team fitness "if the episode ended now", so they sum to the final team
        fitness exactly (up to float rounding of the telescoping sum).
        """
        self._check_can_step()
        a = self.check_actions(actions) if validate else actions
        kernels.step_all(a, self._state, self._geometry, self._task(), self._work, self._scores)
        return self.obs, self.rewards, self.solved

    # ------------------------------------------------------------------ one tick in parts (external motion)
    def begin_tick(self, actions: np.ndarray, validate: bool = True) -> None:
        """`step`'s first part, for an engine that moves the robots itself: advance the clock and turn the
        actions (through the reflex) into headings and velocities in `pose`.  Then move every robot
        (`move_robot_to`) and finish with `end_tick`; `step` is the three in one compiled call."""
        self._check_can_step()
        a = self.check_actions(actions) if validate else actions
        kernels.decide_all(a, self._state, self._task())

    def move_robot_to(self, episode: int, robot: int, x: float, y: float) -> bool:
        """Put a robot where an external engine moved it this tick, under the core's wall rule: a position
        that touches a wall is refused (the robot stays where the tick started; a collision is counted).
        Returns True when the robot moved."""
        return bool(T.settle_robot(int(episode), int(robot), float(x), float(y), self.pose, self.racc, self._pvec,
                                   self.arena.walls, self.arena.boxes))

    def end_tick(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """`step`'s last part: the fitness sample (and automatic signal), sensing for the next tick and the
        rewards.  Returns (obs (B,R,7), rewards (B,), solved (B,)) like `step`."""
        kernels.finish_all(self._state, self._geometry, self._task(), self._work, self._scores)
        return self.obs, self.rewards, self.solved

    def give_signal(self, episode: int, robot: int, on: bool = True) -> None:
        """Set or clear one robot's come-home signal by hand (operator protocols; auto_signal=False)."""
        self.rflag[episode, robot, T.F_SIGNAL] = 1 if on else 0
        self.obs[episode, robot, 6] = 1.0 if on else 0.0

    def resense(self) -> None:
        """Recompute sensing for the coming tick (after robots were moved by hand)."""
        kernels.forget_rays(self._work)
        kernels.sense_all(self.tick + 1, self._state, self._geometry, self._task(), self._work)

    def team_fitness(self) -> tuple[np.ndarray, np.ndarray]:
        """Team fitness and `solved` of each episode as things stand (final once the episode is done)."""
        return self.prev_fit.copy(), self.solved.copy()

    def run_random(self, seed: int = 0, p_left: float = 1 / 3, p_forward: float = 1 / 3,
                   episode_keys: Sequence[int] | np.ndarray | None = None) -> RunResult:
        """Whole episodes of a random team in the compiled loop (random-policy reference, benchmark)."""
        if not (0 <= p_left <= 1 and 0 <= p_forward <= 1 and p_left + p_forward <= 1):
            raise ValueError("p_left and p_forward must be probabilities with p_left + p_forward <= 1")
        self.reset(seed=seed, episode_keys=episode_keys)
        fitness = np.zeros(self.n_episodes)
        solved = np.zeros(self.n_episodes, dtype=np.bool_)
        kernels.run_random(self._state, self._geometry, self._task(), self._work, float(p_left), float(p_forward),
                           (fitness, solved))
        self.prev_fit[:] = fitness
        self.solved[:] = solved
        return RunResult(fitness=fitness, solved=solved, collisions=self.racc[:, :, T.R_COLL].astype(np.int64))

    # ------------------------------------------------------------------ controllers in the loop
    def _teams(self, controllers: TeamControllers) -> TeamControllers:
        """The controllers as a batch of one team per episode (one team given: repeated), checked against the map."""
        ctrl = controllers.as_batch()
        if ctrl.n_robots != self.n_robots:
            raise ValueError(f"controllers are for {ctrl.n_robots} robots, map {self.world.name!r} has "
                             f"{self.n_robots}")
        n_teams = ctrl.w_ih.shape[0]
        if n_teams not in (1, self.n_episodes):
            raise ValueError(f"{n_teams} teams for {self.n_episodes} episodes: give one team or one per episode")
        if n_teams == 1 and self.n_episodes > 1:
            ctrl = ctrl.repeated(self.n_episodes)
        return ctrl

    def run_controllers(self, controllers: TeamControllers, seed: int = 0, poses: np.ndarray | None = None,
                        episode_keys: Sequence[int] | np.ndarray | None = None, record: bool = False) -> RunResult:
        """Run whole episodes with evolved controllers inside the compiled loop (both cores).

        A single team is run in every episode; a batch of B teams runs team b in episode b.
        """
        fitness, solved, traj, _ = self._run(controllers, seed, poses, episode_keys, record,
                                             np.full(self.n_episodes, T.ALL_ROBOTS, dtype=np.int64), False)
        return RunResult(fitness=fitness, solved=solved, collisions=self.racc[:, :, T.R_COLL].astype(np.int64),
                         trajectories=traj if record else None)

    def _run(self, controllers: TeamControllers, seed: int, poses: np.ndarray | None,
             episode_keys: Sequence[int] | np.ndarray | None, record: bool, robots: np.ndarray, sample: bool
             ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """The compiled episodes of `run_controllers` and `run_robot_episodes`: (fitness, solved, trajectories,
        fitness-sample poses)."""
        ctrl = self._teams(controllers)
        self.reset(seed=seed, poses=poses, episode_keys=episode_keys)
        B, R = self.n_episodes, self.n_robots
        n_hidden = ctrl.w_hh.shape[-1]
        hid = np.zeros((B, R, n_hidden), dtype=np.float32)
        out = np.zeros((B, R, 3), dtype=np.float32)
        brain = np.zeros((B, R), dtype=np.int64)
        fitness = np.zeros(B)
        solved = np.zeros(B, dtype=np.bool_)
        T_ = self.params.max_cycles
        traj = np.zeros((B, T_ + 1, R, 4)) if record else np.zeros((1, 1, 1, 4))
        samples = np.zeros((B, T_ // self.params.sample_period, R, 3)) if sample else np.zeros((1, 1, 1, 3))
        nets = (*transposed(ctrl), hid, out, brain, ctrl.decision == "net_input")
        kernels.run_controllers(self._state, self._geometry, self._task(), self._work, nets,
                                kernels.network_scratch(nets[0], n_hidden), (fitness, solved), traj, record,
                                robots, samples, sample)
        self.prev_fit[:] = fitness
        self.solved[:] = solved
        return fitness, solved, traj, samples

    def run_robot_episodes(self, controllers: TeamControllers, robots: np.ndarray, seed: int = 0,
                           episode_keys: Sequence[int] | np.ndarray | None = None) -> RobotEpisodes:
        """Whole episodes in which only some robots play: robot r of episode b when bit r of robots[b] is set
        (the others stay at their start).  Only for robots blind to each other (`robots_see_each_other` off):
        then a robot's episode is a pure function of its controller, its place r, the seed and the episode key,
        and `score_teams` assembles any team from robot episodes played in any batch.  Why: a team and its two
        mirror readings (symmetry "best") share 4 of their 9 robots, so 5 robot episodes score all three."""
        if self.params.robots_see_each_other:
            raise ValueError("run_robot_episodes needs robots that do not see each other: with "
                             "robots_see_each_other a robot's episode depends on its team mates")
        mask = np.asarray(robots, dtype=np.int64)
        if mask.shape != (self.n_episodes,):
            raise ValueError(f"robots must hold one bit mask per episode ({self.n_episodes}), got shape {mask.shape}")
        _, _, _, samples = self._run(controllers, seed, None, episode_keys, False, np.ascontiguousarray(mask), True)
        return RobotEpisodes(samples=samples, finals=self.pose[:, :, :3].copy(), robots=mask.copy())

    def score_teams(self, episodes: RobotEpisodes, src: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(fitness, solved, final poses (T, R, 3)) of T teams assembled from robot episodes of this sim's task
        (`run_robot_episodes`): robot r of team t is robot r of episode src[t, r], which must have played it.
        The same numbers, bit for bit, as the teams' own episodes (kernels.score_teams)."""
        src = np.ascontiguousarray(src, dtype=np.int64)
        n_ep = episodes.samples.shape[0]
        if src.ndim != 2 or src.shape[1] != self.n_robots:
            raise ValueError(f"src must have shape (teams, {self.n_robots}), got {src.shape}")
        if src.size and (src.min() < 0 or src.max() >= n_ep):
            raise ValueError(f"src names episodes outside 0..{n_ep - 1}")
        played = (episodes.robots[src] >> np.arange(self.n_robots)) & 1
        if not played.all():
            t, r = np.argwhere(played == 0)[0]
            raise ValueError(f"robot {r} of team {t} comes from episode {src[t, r]}, which did not play it")
        n, R = src.shape[0], self.n_robots
        state = (np.zeros((n, R, 4)), np.zeros((n, R, 6)), np.zeros((n, R, 7), dtype=np.float32),
                 np.zeros((n, R, 4)), np.zeros((n, R, 3), dtype=np.uint8), np.zeros((n, self.goto.shape[1])),
                 np.zeros((n, 3), dtype=np.int64))
        fitness = np.zeros(n)
        solved = np.zeros(n, dtype=np.bool_)
        kernels.score_teams(episodes.samples, episodes.finals, src, state, self._geometry, self._pvec,
                            (fitness, solved))
        return fitness, solved, state[0][:, :, :3].copy()

    def run_sequential(self, controllers: TeamControllers, seed: int = 0,
                       episode_keys: Sequence[int] | np.ndarray | None = None,
                       settings: sequential.SequentialSettings | None = None,
                       max_lost: Sequence[int] | np.ndarray | None = None) -> sequential.SequentialRecords:
        """Whole episodes of the sequential (real-world) protocol with evolved controllers in the compiled loop
        (core.sequential): one team in every episode, or team b in episode b.  The sim's params must be the
        protocol's task (`sequential.sequential_task`; `sequential.play_sequential` builds such a sim).

        max_lost (per episode, default none): stop episode b once more than max_lost[b] of its stages can no
        longer be done (`SequentialRecords.cut`), for a caller that only needs to know whether it reaches a score."""
        s = settings if settings is not None else sequential.SequentialSettings()
        if self.params != sequential.sequential_task(self.params, s):
            raise ValueError("run_sequential needs the protocol's task: build the sim with "
                             "core.sequential.sequential_task(params, settings) (robots that see each other, no "
                             "automatic signal, max_cycles for the whole protocol)")
        ctrl = self._teams(controllers)
        self.reset(seed=seed, episode_keys=episode_keys)
        try:  # a robot that came home is placed there facing the arena, unless home overlaps the map's walls
            validate_poses(self.world, np.array([[self.world.home[0], self.world.home[1], np.pi / 2]]),
                           self.model.radius, 1)
            can_place = True
        except ValueError:
            can_place = False
        B, R = self.n_episodes, self.n_robots
        limit = np.full(B, 3 * R, dtype=np.int64)
        if max_lost is not None:
            given = np.asarray(max_lost)
            if given.shape != (B,) or given.dtype.kind not in "iu" or (given < 0).any():
                raise ValueError(f"max_lost must hold one non-negative integer per episode ({B}), got "
                                 f"{given.tolist()!r}")
            limit[:] = given
        n_hidden = ctrl.w_hh.shape[-1]
        nets = (*transposed(ctrl), np.zeros((B, R, n_hidden), dtype=np.float32),
                np.zeros((B, R, 3), dtype=np.float32), np.zeros((B, R), dtype=np.int64), ctrl.decision == "net_input")
        out = sequential.SequentialRecords(np.zeros((B, R, 4), dtype=np.int64), np.zeros((B, R, 4), dtype=np.bool_),
                                           np.zeros(B, dtype=np.int64), np.zeros(B, dtype=np.bool_))
        sequential.run_sequential(self._state, self._geometry, self._task(), self._work, nets,
                                  kernels.network_scratch(nets[0], n_hidden), s.vector(),
                                  np.ascontiguousarray(self.pose[:, :, :2]), can_place, limit, out.records,
                                  out.stages, out.ticks, out.cut)
        return out
