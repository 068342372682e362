"""The core's public API: the task's rules for callers outside the compiled loops.

The batch kernels (kernels.py) inline the rules of task.py into their loops.  Callers that get part of a tick
from elsewhere (readings from real sensors, poses from an overhead tracker, positions from a physics engine)
need the same rules on values they give.  The functions here call the very same compiled functions of
task.py and geometry.py, so each rule is written once and the env, the pymunk engine, the hardware env and
the emulator cannot drift from the simulator (tests/envs/test_core_api.py compares them on real episodes):

- `Arena`: a map's geometry as the core reads it (walls, their boxes, sensor directions, POIs, home), with
  `touches_wall`, `move` (the wall rule: a move that would touch a wall is undone) and `ranges` (ray casts);
- `readings_from_ranges`: ray distances -> the six un-floored sensor values (d - radius) / IR range;
- `encode_inputs`: sensor values and signals -> the network's seven inputs (capped at 1, floored, signal last);
- `steer`: an action through the collision-avoidance reflex -> (turn direction, velocity);
- `ScoreKeeper`: the team fitness of an episode from given poses, with the sampling and the automatic signal;
- `policy_coordinates`: the agents' policy-geometry coordinates z.

`BatchSim` (batch.py) is the other half of the API: whole episodes, or one tick split into
`begin_tick` / `move_robot_to` / `end_tick` for an engine that moves the robots itself.
"""
from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from ..khepera import DEFAULT_MODEL, KheperaModel
from ..maps import World, load_map
from . import task as T
from .geometry import cast_rays, sensor_directions, touches_any_wall, wall_boxes
from .params import TaskParams

#: turn directions returned by `steer`
TURN_LEFT, NO_TURN, TURN_RIGHT = 1, 0, -1


def _check_action(action: object) -> int:
    if isinstance(action, (bool, np.bool_)) or not isinstance(action, (int, np.integer)) \
            or action not in (T.LEFT, T.FORWARD, T.RIGHT):
        raise ValueError(f"action must be 0 (left), 1 (forward) or 2 (right), got {action!r}")
    return int(action)


def _six(readings: Sequence[float] | np.ndarray, name: str) -> np.ndarray:
    q = np.asarray(readings, dtype=np.float64)
    if q.shape != (6,):
        raise ValueError(f"{name} must be the six front sensor values (index 0 leftmost), got shape {q.shape}")
    return q


class Arena:
    """A map's geometry in the arrays the compiled core reads: one object per simulator, emulator or engine.

    `walls` (W, 4) x1, y1, x2, y2; `boxes` (W, 4) their bounding boxes; `sensor_dirs` (S, 2) cos and sin of
    each sensor angle (the model's six, or `sensor_angles`); `pois` (P, 2); `home` (2,).  Treat them as
    read-only: the kernels take them as they are.
    """

    def __init__(self, world: World | str = "plus", model: KheperaModel = DEFAULT_MODEL,
                 sensor_angles: Sequence[float] | None = None) -> None:
        self.world = load_map(world)
        self.model = model
        self.walls = np.ascontiguousarray(self.world.walls, dtype=np.float64)
        self.boxes = np.ascontiguousarray(wall_boxes(self.walls))
        self.sensor_dirs = sensor_directions(model.sensor_angles if sensor_angles is None else sensor_angles)
        self.pois = np.ascontiguousarray(self.world.pois, dtype=np.float64)
        self.home = np.ascontiguousarray(self.world.home, dtype=np.float64)

    def compile_rules(self) -> None:
        """Compile (or load from numba's cache) the rules `touches_wall`, `move` and `ranges` run, once, at a start
        pose.  A first call compiles: seconds with a cold cache, tens of milliseconds with a warm one.  A
        real-time caller (the emulator answering a robot's command, a control loop) calls this before its loop, so
        that no tick stalls while robots drive on their last command."""
        x, y, heading = (float(v) for v in self.world.starts[0])
        self.touches_wall(x, y)
        self.move(x, y, x, y)
        self.ranges(x, y, heading)
        self.ranges(x, y, heading, np.array([[x + 50.0, y]]))

    def touches_wall(self, x: float, y: float) -> bool:
        """True when a robot centred at (x, y) is closer than its radius to any wall."""
        return bool(touches_any_wall(float(x), float(y), self.model.radius, self.walls, self.boxes))

    def move(self, x: float, y: float, new_x: float, new_y: float) -> tuple[float, float, bool]:
        """The wall rule: a robot moving from (x, y) to (new_x, new_y) ends there, or stays at (x, y) when it
        would touch a wall (no sliding).  Returns (x, y, touched)."""
        ex, ey, touched = T.wall_revert(float(x), float(y), float(new_x), float(new_y), self.model.radius,
                                        self.walls, self.boxes)
        return float(ex), float(ey), bool(touched)

    def ranges(self, x: float, y: float, heading: float, others: np.ndarray | None = None) -> np.ndarray:
        """Centre-to-hit distance of each sensor ray (the model's sensor range when nothing is hit), against
        the walls and the robots centred at `others` (k, 2), if given (robots that see each other)."""
        oth = np.zeros((1, 2)) if others is None or len(others) == 0 \
            else np.ascontiguousarray(others, dtype=np.float64).reshape(-1, 2)
        n_others = 0 if others is None else len(others)
        out = np.empty(self.sensor_dirs.shape[0])
        cast_rays(float(x), float(y), float(heading), self.sensor_dirs, self.model.sensor_range, self.walls,
                  self.boxes, oth, n_others, self.model.radius, out, np.empty(self.walls.shape[0], dtype=np.int64))
        return out


def readings_from_ranges(distances: Sequence[float] | np.ndarray,
                         model: KheperaModel = DEFAULT_MODEL) -> np.ndarray:
    """Ray distances (from the robot's centre) -> un-floored sensor values (d - radius) / IR range in float32,
    as the core computes them for the inputs and the reflex (1 = free at the IR range, 0 = touching)."""
    d = np.asarray(distances, dtype=np.float64)
    f_radius, f_ir = np.float32(model.radius), np.float32(model.ir_range)
    return np.array([T.unit_reading(v, f_radius, f_ir) for v in d.ravel()], dtype=np.float32).reshape(d.shape)


def encode_inputs(readings: Sequence[Sequence[float]] | np.ndarray, signal: Sequence[float] | np.ndarray,
                  floor: float = DEFAULT_MODEL.sensor_floor, ceiling: float = 1.0) -> np.ndarray:
    """The network inputs (R, 7) float32 of R robots: each of the six un-floored sensor values (R, 6) capped at
    1, read as 1 at or above `ceiling` (TaskParams.input_ceiling; 1 changes nothing) and as 0 at or below
    `floor`, then the robot's come-home signal (0 or 1)."""
    q = np.asarray(readings, dtype=np.float32)
    if q.ndim != 2 or q.shape[1] != 6:
        raise ValueError(f"readings must have shape (robots, 6), got {q.shape}")
    sig = np.asarray(signal, dtype=np.float32)
    if sig.shape != (q.shape[0],):
        raise ValueError(f"signal must hold one value per robot ({q.shape[0]}), got shape {sig.shape}")
    f_floor, f_ceil = np.float32(floor), np.float32(ceiling)
    out = np.empty((q.shape[0], 7), dtype=np.float32)
    for r in range(q.shape[0]):
        for j in range(6):
            out[r, j] = T.input_value(q[r, j], f_floor, f_ceil)
    out[:, 6] = sig
    return out


def steer(action: int, readings: Sequence[float] | np.ndarray, velocity: float,
          speed: float = DEFAULT_MODEL.speed, floor: float = DEFAULT_MODEL.sensor_floor,
          reflex: bool = True, arc: bool = False) -> tuple[int, float]:
    """An action (0 left, 1 forward, 2 right) through the collision-avoidance reflex -> (turn, velocity).

    `readings` are the six un-floored sensor values the robot last saw (index 0 leftmost, compared in float32
    with `floor`), `velocity` its current forward velocity and `speed` the forward speed.  `turn` is
    TURN_LEFT (+1), NO_TURN (0) or TURN_RIGHT (-1): one turning step this tick.  The reflex keeps the velocity
    when it turns (a driving robot arcs round the obstacle) and stops the robot when the front is blocked; with
    `arc` (TaskParams.reflex_arc) its side branches drive at `speed` instead, so a standing robot arcs too.
    """
    act = _check_action(action)
    q = _six(readings, "readings").astype(np.float32)
    response = T.REFLEX_CLEAR
    if reflex:
        response = T.reflex_response(q[0], q[1], q[2], q[3], q[4], q[5], np.float32(floor))
    turn, v = T.steer(act, response, float(velocity), float(speed), bool(arc))
    return int(turn), float(v)


def policy_coordinates(n_robots: int) -> np.ndarray:
    """Policy-geometry coordinates z_k = -1 + k * 2/(n-1) of n robots, accumulated in float32 as the original
    laid out its substrate rows (exactly -1, 0, 1 for three robots; 0 for one robot)."""
    if isinstance(n_robots, bool) or not isinstance(n_robots, (int, np.integer)) or n_robots < 1:
        raise ValueError(f"n_robots must be a positive integer, got {n_robots!r}")
    out = np.zeros(int(n_robots), dtype=np.float32)
    if n_robots == 1:
        return out
    step = np.float32(2.0 / (n_robots - 1))
    z = np.float32(-1.0)
    for k in range(int(n_robots)):
        out[k] = z
        z = np.float32(z + step)
    return out


class ScoreKeeper:
    """The task's score for one episode whose robots move elsewhere (real robots under an overhead tracker).

    Give it the poses after every tick (`advance`): it samples the fitness every `sample_period` ticks and
    gives the automatic come-home signal at `signal_tick`, running the core's own `score_tick` and
    `team_fitness` on its state, so `fitness()` means exactly what it means in simulation.  Without poses,
    `advance()` only runs the signal schedule (the signals are then right, the score is unknown).
    """

    def __init__(self, world: World | str = "plus", params: TaskParams | None = None,
                 model: KheperaModel = DEFAULT_MODEL, n_robots: int | None = None) -> None:
        self.arena = Arena(world, model)
        self.model = model
        n = self.arena.world.n_robots if n_robots is None else n_robots
        if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 1:
            raise ValueError(f"n_robots must be a positive integer, got {n_robots!r}")
        self.n_robots = int(n)
        self.params = params if params is not None else TaskParams()
        self._pose = np.zeros((1, self.n_robots, 4))
        self._racc = np.zeros((1, self.n_robots, 4))
        self._rflag = np.zeros((1, self.n_robots, 3), dtype=np.uint8)
        self._goto = np.zeros((1, self.arena.pois.shape[0]))
        self._est = np.zeros((1, 3), dtype=np.int64)
        self.reset()

    @property
    def params(self) -> TaskParams:
        return self._params

    @params.setter
    def params(self, params: TaskParams) -> None:
        if not isinstance(params, TaskParams):
            raise TypeError(f"params must be a TaskParams, got {type(params).__name__}")
        self._params = params
        self._pvec = params.vector(self.model)

    def reset(self, poses: np.ndarray | None = None) -> None:
        """A new episode: tick 0, no signal, no credit; the start `poses` (n_robots, 3) if known."""
        self._pose[:] = np.nan
        self._pose[0, :, T.V] = 0.0
        if poses is not None:
            self._pose[0, :, :3] = self._check_poses(poses)
        self._racc[:] = 0.0
        self._rflag[:] = 0
        self._goto[:] = 0.0
        self._est[:] = 0
        self._scored = True

    def compile_rules(self) -> None:
        """Compile (or load from numba's cache) the rules `advance` and `fitness` run, on scratch copies of this
        keeper's state (its own state is untouched), and the arena's (`Arena.compile_rules`): see there for why."""
        self.arena.compile_rules()
        pose = np.zeros_like(self._pose)
        pose[0, :, :2] = self.arena.home
        racc, rflag, goto, est = (np.zeros_like(a) for a in (self._racc, self._rflag, self._goto, self._est))
        tick = int(self.params.sample_period)
        T.signal_due(0, tick, est, self._pvec)
        T.signal_team(0, rflag, est)
        T.score_tick(0, tick, pose, racc, rflag, goto, est, self.arena.pois, self.arena.home, self._pvec)
        T.team_fitness(0, pose, racc, rflag, goto, est, self.arena.home)

    def _check_poses(self, poses: np.ndarray) -> np.ndarray:
        arr = np.asarray(poses, dtype=np.float64)
        if arr.shape != (self.n_robots, 3):
            raise ValueError(f"poses must have shape ({self.n_robots}, 3) of (x, y, heading), got {arr.shape}")
        return arr

    @property
    def tick(self) -> int:
        return int(self._est[0, T.E_TICK])

    @property
    def poses(self) -> np.ndarray:
        """(n_robots, 3) x, y, heading given at the last tick (NaN before any); a read-only view."""
        view = self._pose[0, :, :3]
        view.flags.writeable = False
        return view

    @property
    def signals(self) -> np.ndarray:
        """(n_robots,) come-home signal of each robot, 0 or 1 (uint8); a read-only view."""
        view = self._rflag[0, :, T.F_SIGNAL]
        view.flags.writeable = False
        return view

    def set_signal(self, robot: int, on: bool = True) -> None:
        """Set or clear one robot's come-home signal by hand (an operator's call)."""
        if not 0 <= robot < self.n_robots:
            raise ValueError(f"robot must be in 0..{self.n_robots - 1}, got {robot!r}")
        self._rflag[0, robot, T.F_SIGNAL] = 1 if on else 0

    def advance(self, poses: np.ndarray | None = None) -> None:
        """One tick has passed; `poses` (n_robots, 3) are where the robots are now (None: unknown)."""
        tick = self.tick + 1
        self._est[0, T.E_TICK] = tick
        if poses is None:
            self._scored = False
            if T.signal_due(0, tick, self._est, self._pvec):
                T.signal_team(0, self._rflag, self._est)
            return
        self._pose[0, :, :3] = self._check_poses(poses)
        T.score_tick(0, tick, self._pose, self._racc, self._rflag, self._goto, self._est, self.arena.pois,
                     self.arena.home, self._pvec)

    def fitness(self) -> tuple[float, bool]:
        """Team fitness and `solved` if the episode ended now."""
        if not self._scored:
            raise RuntimeError("the score needs the poses of every tick; some ticks were advanced without them")
        fit, solved = T.team_fitness(0, self._pose, self._racc, self._rflag, self._goto, self._est,
                                     self.arena.home)
        return float(fit), bool(solved)


#: A robot is home within this Manhattan distance of the home point (the fitness's reachGoal).
HOME_REACHED = T.HOME_REACHED
#: A post counts as covered within this Manhattan distance (the fitness's allClose).
POST_REACHED = T.POI_CLOSE


def manhattan(p: Sequence[float], q: Sequence[float]) -> float:
    """|px - qx| + |py - qy|: the distance every radius of the task (home, posts) is measured in."""
    return float(T._manhattan(float(p[0]), float(p[1]), float(q[0]), float(q[1])))


__all__ = ["Arena", "ScoreKeeper", "encode_inputs", "manhattan", "policy_coordinates", "readings_from_ranges",
           "steer", "HOME_REACHED", "POST_REACHED", "TURN_LEFT", "NO_TURN", "TURN_RIGHT"]
